#include "stemmap/stems/distance_sampling.h"

#include <gtest/gtest.h>

#include <cmath>

#include "stemmap/core/rng.h"

namespace stemmap::stems {
namespace {

struct Scan {
  std::vector<double> distances_m, dbh_cm;
  int stems_in_plot = 0;
  double basal_area_m2 = 0.0;
};

// Stems spread evenly over a plot of radius `radius_m` (outside the 1-m arm), each found with
// probability g(r).
template <typename G>
Scan ScanOfAPlot(int stems, double radius_m, G g, uint64_t seed) {
  Rng rng(seed);
  Scan s;
  while (s.stems_in_plot < stems) {
    const double r = radius_m * std::sqrt(rng.Uniform());
    if (r < 1.0) continue;
    ++s.stems_in_plot;
    const double dbh = rng.Uniform(10.0, 50.0);
    s.basal_area_m2 += M_PI * std::pow(dbh / 200.0, 2);
    if (rng.Uniform() < g(r)) {
      s.distances_m.push_back(r);
      s.dbh_cm.push_back(dbh);
    }
  }
  return s;
}

TEST(DistanceSampling, TheHalfNormalFitRecoversItsScale) {
  const double radius = 10.0;
  const Scan s = ScanOfAPlot(
      2000, radius, [](double r) { return std::exp(-r * r / 72.0); }, 1);
  const DetectionFit fit = FitHalfNormal(s.distances_m, radius);
  EXPECT_EQ(fit.model, DetectionModel::kHalfNormal);
  EXPECT_NEAR(fit.sigma_m, 6.0, 0.4);
  EXPECT_NEAR(fit.g(6.0), std::exp(-0.5), 0.04);
  const double found_share = static_cast<double>(s.distances_m.size()) / s.stems_in_plot;
  EXPECT_NEAR(fit.detection_probability, found_share, 0.04);
}

TEST(DistanceSampling, TheCorrectionRestoresTheStemsAndBasalAreaOcclusionHid) {
  const double radius = 12.0;
  auto g = [](double r) { return 1 - std::exp(-std::pow(r / 7.0, -6.0)); };
  const Scan s = ScanOfAPlot(600, radius, g, 5);
  OcclusionOptions o;
  o.bootstrap_draws = 100;
  const OcclusionCorrection c = CorrectForOcclusion(o, s.distances_m, s.dbh_cm, radius);
  const double area_ha = M_PI * radius * radius / 1e4;
  const double true_per_ha = s.stems_in_plot / area_ha;
  EXPECT_LT(s.distances_m.size(), 0.6 * s.stems_in_plot);  // much was hidden
  EXPECT_NEAR(c.stems_per_ha / true_per_ha, 1.0, 0.08);
  EXPECT_NEAR(c.basal_area_m2_per_ha / (s.basal_area_m2 / area_ha), 1.0, 0.1);
  EXPECT_LE(c.stems_per_ha_95.low, true_per_ha);
  EXPECT_GE(c.stems_per_ha_95.high, true_per_ha);
}

TEST(DistanceSampling, AHazardRateShoulderIsFittedAsOne) {
  // Everything found out to about 6 m, then a quick fall: the hazard rate's shape.
  const double radius = 12.0;
  auto g = [](double r) { return 1 - std::exp(-std::pow(r / 7.0, -6.0)); };
  const Scan s = ScanOfAPlot(3000, radius, g, 2);
  const DetectionFit fit = FitDetection(s.distances_m, radius);
  EXPECT_EQ(fit.model, DetectionModel::kHazardRate);
  EXPECT_NEAR(fit.sigma_m, 7.0, 0.5);
  EXPECT_NEAR(fit.shape, 6.0, 1.5);
  const double found_share = static_cast<double>(s.distances_m.size()) / s.stems_in_plot;
  EXPECT_NEAR(fit.detection_probability, found_share, 0.05);
}

TEST(DistanceSampling, APlotSeenWholeNeedsNoCorrection) {
  const Scan s = ScanOfAPlot(
      2000, 10.0, [](double) { return 1.0; }, 3);
  const DetectionFit fit = FitDetection(s.distances_m, 10.0);
  EXPECT_GT(fit.detection_probability, 0.97);
}

TEST(DistanceSampling, TooFewStemsLeaveTheFiguresAsListed) {
  const std::vector<double> r = {2.0, 5.0, 7.0}, d = {20.0, 30.0, 40.0};
  const OcclusionCorrection c = CorrectForOcclusion({}, r, d, 10.0);
  EXPECT_EQ(c.fit.model, DetectionModel::kNone);
  EXPECT_DOUBLE_EQ(c.stems_per_ha, 3 / (M_PI * 100 / 1e4));
  EXPECT_EQ(c.stems_per_ha_95.low, c.stems_per_ha);
}

TEST(DistanceSampling, TheIntervalsRepeatForTheSameSeed) {
  const Scan s = ScanOfAPlot(
      30, 10.0, [](double r) { return std::exp(-r * r / 50.0); }, 4);
  OcclusionOptions o;
  o.bootstrap_draws = 200;
  const OcclusionCorrection a = CorrectForOcclusion(o, s.distances_m, s.dbh_cm, 10.0);
  const OcclusionCorrection b = CorrectForOcclusion(o, s.distances_m, s.dbh_cm, 10.0);
  EXPECT_EQ(a.stems_per_ha_95.low, b.stems_per_ha_95.low);
  EXPECT_EQ(a.basal_area_m2_per_ha_95.high, b.basal_area_m2_per_ha_95.high);
  EXPECT_LE(a.stems_per_ha_95.low, a.stems_per_ha);
  EXPECT_GE(a.stems_per_ha_95.high, a.stems_per_ha);
}

}  // namespace
}  // namespace stemmap::stems
