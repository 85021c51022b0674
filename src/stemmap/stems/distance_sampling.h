#pragma once

// Occlusion correction by distance sampling, as single-scan TLS tools do (FORTLS): the stems found
// thin out with distance from the plot centre because nearer stems hide farther ones; a detection
// function g(r) fitted to the found stems' distances tells what share of the plot's stems a scan
// from the centre finds, and the figures are divided by it.
//
// Point transect within the plot radius R: a stem at distance r is found with probability g(r),
// g(0) = 1, so found distances have the density f(r) = r·g(r) / ∫₀ᴿ r·g(r) dr, and a stem of the
// plot is found with probability P = 2/R² ∫₀ᴿ r·g(r) dr. Models:
//   half-normal  g(r) = exp(−r² / 2σ²)              ∫₀ᴿ r·g = σ²(1 − exp(−R²/2σ²))
//   hazard-rate  g(r) = 1 − exp(−(r/σ)^−b), b ≥ 1   ∫₀ᴿ r·g by Simpson's rule
// each fitted by maximum likelihood, the one with the lower AIC kept. Corrected stems/ha is
// n / (P·area) and basal area Σ ba / (P·area); intervals by resampling the found stems.
#include <cstdint>
#include <string_view>
#include <vector>

#include "stemmap/stems/interval.h"

namespace stemmap::stems {

enum class DetectionModel { kNone, kHalfNormal, kHazardRate };
std::string_view DetectionModelName(DetectionModel model);  // "half_normal", ...

struct DetectionFit {
  DetectionModel model = DetectionModel::kNone;  // kNone: too few stems to fit
  double sigma_m = 0.0;                          // scale
  double shape = 0.0;                            // hazard-rate b
  double log_likelihood = 0.0, aic = 0.0;
  double detection_probability = 1.0;  // P: share of the plot's stems a scan finds
  double g(double r_m) const;          // the detection function
};

// Each model's maximum-likelihood fit to stems found at `distances_m` (within `radius_m`).
DetectionFit FitHalfNormal(const std::vector<double>& distances_m, double radius_m);
DetectionFit FitHazardRate(const std::vector<double>& distances_m, double radius_m);

// The model with the lower AIC for stems found at `distances_m` (those within `radius_m`). Fewer
// than `min_stems` stems: model kNone, P = 1. The two models can fit the found distances alike
// and still differ in P, as the few stems near the centre leave g's shoulder loose; the summary
// gives the model chosen.
DetectionFit FitDetection(const std::vector<double>& distances_m, double radius_m,
                          int min_stems = 5);

struct OcclusionOptions {
  int bootstrap_draws = 200;  // resamples of the found stems for the intervals
  uint64_t seed = 1;
  int min_stems = 5;  // fewer stems in the plot: no correction
  void Check() const;
};

struct OcclusionCorrection {
  DetectionFit fit;
  double stems_per_ha = 0.0, basal_area_m2_per_ha = 0.0;
  Interval stems_per_ha_95, basal_area_m2_per_ha_95;
};

// The plot's figures corrected for the stems a scan from the centre does not see: stems at
// `distances_m` with `dbh_cm`, plot radius `radius_m` (horizontal).
OcclusionCorrection CorrectForOcclusion(const OcclusionOptions& options,
                                        const std::vector<double>& distances_m,
                                        const std::vector<double>& dbh_cm, double radius_m);

}  // namespace stemmap::stems
