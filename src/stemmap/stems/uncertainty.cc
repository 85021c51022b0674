#include "stemmap/stems/uncertainty.h"

#include <cmath>

#include "stemmap/core/error.h"

namespace stemmap::stems {

void UncertaintyOptions::Check() const {
  for (double v : {edge_bias_px, section_share, estimator_gap_share, one_sided_share,
                   occluded_share, no_silhouette_share, depth_smeared_share, few_views_share}) {
    if (!(v >= 0)) throw InputError("the DBH uncertainty's terms must not be negative");
  }
  for (double c : {confidence_two_sided, confidence_one_sided, confidence_cloud_only,
                   confidence_silhouette_only}) {
    if (!(c >= 0 && c <= 1)) throw InputError("a detection confidence must lie in [0, 1]");
  }
}

double DbhSd(const UncertaintyOptions& o, const Stem& s, double px_m) {
  // The silhouettes' width, or the cloud's (no fit stood, or another DBH method was asked for).
  const bool from_silhouettes = s.dbh_tangent_m > 0 && std::abs(s.dbh_m - s.dbh_tangent_m) < 1e-9;
  const double fit_sd = from_silhouettes ? s.dbh_tangent_sd_m : s.dbh_sd_m;
  // Two silhouettes, each biased on its own.
  const double edges = std::sqrt(2.0) * o.edge_bias_px * px_m;
  double var = fit_sd * fit_sd + edges * edges + std::pow(o.section_share * s.dbh_m, 2);
  if (s.flags.Has(StemFlag::kWidthFromStand)) {
    // Anywhere between the width seen and the widest hidden: two SD reach the farther end.
    const double reach_m = std::max(s.dbh_m - s.dbh_seen_m, s.dbh_hidden_max_m - s.dbh_m);
    return std::sqrt(edges * edges + std::pow(o.section_share * s.dbh_m, 2) +
                     std::pow(0.5 * reach_m, 2));
  }
  const double cloud_m = s.dbh_slice_m > 0 ? s.dbh_slice_m : s.dbh_circle_m;
  if (s.dbh_tangent_m > 0 && cloud_m > 0) {
    var += std::pow(o.estimator_gap_share * (s.dbh_tangent_m - cloud_m), 2);
  }
  auto add_share = [&](StemFlag flag, double share) {
    if (s.flags.Has(flag)) var += std::pow(share * s.dbh_m, 2);
  };
  add_share(StemFlag::kOneSided, o.one_sided_share);
  add_share(StemFlag::kOccluded, o.occluded_share);
  add_share(StemFlag::kNoSilhouette, o.no_silhouette_share);
  add_share(StemFlag::kDepthSmeared, o.depth_smeared_share);
  add_share(StemFlag::kFewViews, o.few_views_share);
  return std::sqrt(var);
}

double DetectionConfidence(const UncertaintyOptions& o, const Stem& s) {
  if (s.flags.Has(StemFlag::kSilhouetteOnly)) return o.confidence_silhouette_only;
  if (s.flags.Has(StemFlag::kNoSilhouette)) return o.confidence_cloud_only;
  if (s.flags.Has(StemFlag::kOneSided)) return o.confidence_one_sided;
  return o.confidence_two_sided;
}

}  // namespace stemmap::stems
