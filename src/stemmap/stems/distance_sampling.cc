#include "stemmap/stems/distance_sampling.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"

namespace stemmap::stems {

namespace {

// The argument in [lo, hi] that maximises a unimodal `f`, by golden-section search.
double GoldenMax(const std::function<double(double)>& f, double lo, double hi, double tol) {
  const double r = (std::sqrt(5.0) - 1) / 2;
  double a = lo, b = hi;
  double c = b - r * (b - a), d = a + r * (b - a);
  double fc = f(c), fd = f(d);
  while (b - a > tol) {
    if (fc > fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - r * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + r * (b - a);
      fd = f(d);
    }
  }
  return 0.5 * (a + b);
}

// The argument in [lo, hi] that maximises `f`: the best of `steps` + 1 evenly spaced points, then
// golden-section search between its neighbours. The likelihoods have plateaus (a scale far beyond
// the plot finds everything alike), on which a golden search alone can settle.
double GridThenGoldenMax(const std::function<double(double)>& f, double lo, double hi, int steps,
                         double tol) {
  const double step = (hi - lo) / steps;
  int best = 0;
  double best_value = f(lo);
  for (int i = 1; i <= steps; ++i) {
    const double v = f(lo + i * step);
    if (v > best_value) {
      best_value = v;
      best = i;
    }
  }
  return GoldenMax(f, lo + std::max(0, best - 1) * step, lo + std::min(steps, best + 1) * step,
                   tol);
}

// Scales searched, as log σ: from 5 cm (almost nothing found beyond the arm) to 1 km (nothing
// hidden within any plot).
constexpr double kLogSigmaMin = -3.0, kLogSigmaMax = 6.9;
constexpr int kLogSigmaSteps = 20;
constexpr double kLogTolerance = 1e-3;
constexpr double kShapeMin = 1.0, kShapeMax = 15.0;
constexpr int kShapeSteps = 7;
constexpr double kShapeTolerance = 1e-2;
constexpr int kSimpsonIntervals = 32;

double HalfNormalG(double r, double sigma) { return std::exp(-r * r / (2 * sigma * sigma)); }

// ∫₀ᴿ r·exp(−r²/2σ²) dr, written with expm1 so that large σ keeps its digits.
double HalfNormalIntegral(double radius, double sigma) {
  return -sigma * sigma * std::expm1(-radius * radius / (2 * sigma * sigma));
}

double HazardRateG(double r, double sigma, double shape) {
  if (r <= 0) return 1.0;
  return -std::expm1(-std::pow(r / sigma, -shape));
}

// The hazard rate's log-likelihood with the logs of the distances and of Simpson's nodes taken
// once: g(r) = −expm1(−exp(−b·(log r − log σ))).
class HazardRateLikelihood {
 public:
  HazardRateLikelihood(const std::vector<double>& r, double radius) : n_(r.size()) {
    for (double x : r) log_r_.push_back(std::log(std::max(x, 1e-9)));
    const double h = radius / kSimpsonIntervals;
    for (int i = 1; i <= kSimpsonIntervals; ++i) {  // the node at 0 adds 0·g(0)
      const double w = i == kSimpsonIntervals ? 1.0 : (i % 2 ? 4.0 : 2.0);
      node_log_r_.push_back(std::log(i * h));
      node_weight_.push_back(w * i * h * h / 3.0);
    }
  }
  double Integral(double log_sigma, double shape) const {
    double sum = 0.0;
    for (size_t i = 0; i < node_log_r_.size(); ++i) {
      sum += node_weight_[i] * G(node_log_r_[i], log_sigma, shape);
    }
    return sum;
  }
  // log L = Σ log g(rᵢ) − n·log ∫₀ᴿ r·g(r) dr (the Σ log rᵢ term is the same for every model).
  double operator()(double log_sigma, double shape) const {
    double ll = -static_cast<double>(n_) * std::log(Integral(log_sigma, shape));
    for (double lr : log_r_) ll += std::log(std::max(1e-300, G(lr, log_sigma, shape)));
    return ll;
  }

 private:
  static double G(double log_r, double log_sigma, double shape) {
    return -std::expm1(-std::exp(-shape * (log_r - log_sigma)));
  }
  size_t n_;
  std::vector<double> log_r_, node_log_r_, node_weight_;
};

// log L = Σ log g(rᵢ) − n·log ∫₀ᴿ r·g(r) dr (the Σ log rᵢ term is the same for every model).
double HalfNormalLogLikelihood(const std::vector<double>& r, double radius, double sigma) {
  double ll = -static_cast<double>(r.size()) * std::log(HalfNormalIntegral(radius, sigma));
  for (double x : r) ll += -x * x / (2 * sigma * sigma);
  return ll;
}

}  // namespace

std::string_view DetectionModelName(DetectionModel model) {
  switch (model) {
    case DetectionModel::kNone:
      return "none";
    case DetectionModel::kHalfNormal:
      return "half_normal";
    case DetectionModel::kHazardRate:
      return "hazard_rate";
  }
  return "none";
}

double DetectionFit::g(double r_m) const {
  switch (model) {
    case DetectionModel::kHalfNormal:
      return HalfNormalG(r_m, sigma_m);
    case DetectionModel::kHazardRate:
      return HazardRateG(r_m, sigma_m, shape);
    case DetectionModel::kNone:
      break;
  }
  return 1.0;
}

DetectionFit FitHalfNormal(const std::vector<double>& r, double radius) {
  const double log_sigma =
      GridThenGoldenMax([&](double s) { return HalfNormalLogLikelihood(r, radius, std::exp(s)); },
                        kLogSigmaMin, kLogSigmaMax, kLogSigmaSteps, kLogTolerance);
  DetectionFit f;
  f.model = DetectionModel::kHalfNormal;
  f.sigma_m = std::exp(log_sigma);
  f.log_likelihood = HalfNormalLogLikelihood(r, radius, f.sigma_m);
  f.aic = 2 * 1 - 2 * f.log_likelihood;
  f.detection_probability = 2 * HalfNormalIntegral(radius, f.sigma_m) / (radius * radius);
  return f;
}

DetectionFit FitHazardRate(const std::vector<double>& r, double radius) {
  const HazardRateLikelihood likelihood(r, radius);
  auto best_log_sigma = [&](double shape) {
    return GridThenGoldenMax([&](double s) { return likelihood(s, shape); }, kLogSigmaMin,
                             kLogSigmaMax, kLogSigmaSteps, kLogTolerance);
  };
  const double shape = GridThenGoldenMax([&](double b) { return likelihood(best_log_sigma(b), b); },
                                         kShapeMin, kShapeMax, kShapeSteps, kShapeTolerance);
  const double log_sigma = best_log_sigma(shape);
  DetectionFit f;
  f.model = DetectionModel::kHazardRate;
  f.shape = shape;
  f.sigma_m = std::exp(log_sigma);
  f.log_likelihood = likelihood(log_sigma, shape);
  f.aic = 2 * 2 - 2 * f.log_likelihood;
  f.detection_probability = 2 * likelihood.Integral(log_sigma, shape) / (radius * radius);
  return f;
}

DetectionFit FitDetection(const std::vector<double>& distances_m, double radius_m, int min_stems) {
  if (!(radius_m > 0)) throw InputError("distance sampling needs a positive plot radius");
  std::vector<double> r;
  for (double d : distances_m) {
    if (d >= 0 && d <= radius_m) r.push_back(d);
  }
  if (static_cast<int>(r.size()) < min_stems) return {};
  const DetectionFit half_normal = FitHalfNormal(r, radius_m);
  const DetectionFit hazard_rate = FitHazardRate(r, radius_m);
  return hazard_rate.aic < half_normal.aic ? hazard_rate : half_normal;
}

void OcclusionOptions::Check() const {
  if (bootstrap_draws < 100) throw InputError("the occlusion intervals need at least 100 draws");
  if (min_stems < 3) throw InputError("a detection function needs at least 3 stems to fit");
}

OcclusionCorrection CorrectForOcclusion(const OcclusionOptions& o,
                                        const std::vector<double>& distances_m,
                                        const std::vector<double>& dbh_cm, double radius_m) {
  o.Check();
  const double area_ha = M_PI * radius_m * radius_m / 1e4;
  auto figures = [&](const std::vector<double>& r, const std::vector<double>& d,
                     const DetectionFit& fit) {
    double basal_m2 = 0.0;
    for (double x : d) basal_m2 += M_PI * std::pow(x / 200.0, 2);
    const double p = fit.detection_probability;
    return std::pair{r.size() / (p * area_ha), basal_m2 / (p * area_ha)};
  };
  OcclusionCorrection c;
  c.fit = FitDetection(distances_m, radius_m, o.min_stems);
  std::tie(c.stems_per_ha, c.basal_area_m2_per_ha) = figures(distances_m, dbh_cm, c.fit);
  c.stems_per_ha_95 = {c.stems_per_ha, c.stems_per_ha};
  c.basal_area_m2_per_ha_95 = {c.basal_area_m2_per_ha, c.basal_area_m2_per_ha};
  if (c.fit.model == DetectionModel::kNone) return c;
  Rng rng(o.seed);
  std::vector<double> per_ha, basal, r(distances_m.size()), d(dbh_cm.size());
  const int n = static_cast<int>(distances_m.size());
  for (int k = 0; k < o.bootstrap_draws; ++k) {
    for (int i = 0; i < n; ++i) {
      const int j = rng.UniformInt(0, n - 1);
      r[i] = distances_m[j];
      d[i] = dbh_cm[j];
    }
    DetectionFit fit = FitDetection(r, radius_m, o.min_stems);
    const auto [stems, ba] = figures(r, d, fit);
    per_ha.push_back(stems);
    basal.push_back(ba);
  }
  c.stems_per_ha_95 = Percentiles95(per_ha);
  c.basal_area_m2_per_ha_95 = Percentiles95(basal);
  return c;
}

}  // namespace stemmap::stems
