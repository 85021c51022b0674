#include "stemmap/stems/measure.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "stemmap/core/error.h"
#include "stemmap/stems/ground.h"
#include "stemmap/stems/refine.h"

namespace stemmap::stems {

void MeasureOptions::Check() const {
  stems.Check();
  tangent.Check();
  bark_depth.Check();
  votes.Check();
  if (min_dbh_cm < 0) throw InputError("--min-dbh must not be negative");
  if (!(sapling_outline_max_dbh_cm >= 0 && sapling_outline_max_dbh_cm <= 30)) {
    throw InputError("the widest sapling's outline must lie in [0, 30] cm");
  }
  ground.Check();
  uncertainty.Check();
  if (!(one_sided_min_cloud_radius_m >= 0)) {
    throw InputError("the cloud radius a one-sided fit may widen must not be negative");
  }
  if (!(one_sided_max_over_cloud >= 1)) {
    throw InputError("a one-sided fit's bound over the cloud's width must be at least 1");
  }
  if (!(min_bark_gap_m >= 0 && min_bark_gap_m < 1)) {
    throw InputError("the smallest gap between two stems' bark must lie in [0, 1) m");
  }
  if (!(larger_cloud_part_gap_m >= 0)) {
    throw InputError(
        "the gap within which a larger cloud's part joins a stem must not be negative");
  }
  if (!(fit_on_cloud_max_pass_through >= 0 && fit_on_cloud_max_pass_through < 1)) {
    throw InputError("the share of rays that may pass a fit on the cloud must lie in [0, 1)");
  }
  if (!(larger_cloud_only_max_rms_px >= 0)) {
    throw InputError("the rms a larger cloud's stem's silhouettes may keep must not be negative");
  }
  if (!(wide_fit_scale >= 1)) {
    throw InputError(
        "the width over the cloud's that needs the bark to line up must be at least 1");
  }
  if (!(wide_fit_min_bark_ncc >= -1 && wide_fit_min_bark_ncc <= 1)) {
    throw InputError("the bark correlation a wide fit needs must lie in [-1, 1]");
  }
  if (!(loose_fit_rms_px > 0)) {
    throw InputError("the rms beyond which a narrower fit is loose must be positive");
  }
  if (!(tight_fit_rms_px > 0 && tight_fit_rms_px <= loose_fit_rms_px)) {
    throw InputError(
        "the rms of a tight fit must be positive and no more than that of a loose one");
  }
  if (!(min_judged_px_m >= 0 && min_judged_px_m <= 0.02)) {
    throw InputError("the least a pixel counts as at a stem must lie in [0, 0.02] m");
  }
  if (!(loose_wider_max_over_cloud >= 1)) {
    throw InputError("the width over the cloud's a loose wider fit may reach must be at least 1");
  }
  if (!(narrower_on_bark_two_sided_share >= 0 && narrower_on_bark_two_sided_share <= 0.5)) {
    throw InputError(
        "the two-sided share of a narrower fit whose bark lines up must lie in [0, 0.5]");
  }
  if (!(whole_in_wide_part_two_sided_share >= 0 && whole_in_wide_part_two_sided_share <= 1)) {
    throw InputError(
        "the share of views a fit in a wide part shows both sides in must lie in [0, 1]");
  }
  if (!(narrower_max_bark_past_outline >= 0)) {
    throw InputError("the share of bark past a narrower fit's outline must not be negative");
  }
  if (!(outline_over_bark_two_sided_share >= 0 && outline_over_bark_two_sided_share <= 1)) {
    throw InputError(
        "the two-sided share of an outline that outweighs its bark must lie in [0, 1]");
  }
  if (!(outline_over_bark_rms_px >= 0)) {
    throw InputError("the rms of an outline that outweighs its bark must not be negative");
  }
  if (!(outline_over_bark_cloud_share >= 0)) {
    throw InputError(
        "the cloud's share within which an outline outweighs its bark must not be negative");
  }
  if (!(outline_over_bark_smear_m >= 0)) {
    throw InputError(
        "the cloud's smear an outline that outweighs its bark may be narrower by "
        "must not be negative");
  }
  if (!(weak_on_bark_max_rms_px >= 0)) {
    throw InputError("the rms of a weak part's outline on its bark must not be negative");
  }
  if (!(leafy_edge_scatter_m >= 0 && leafy_edge_scatter_px >= 0)) {
    throw InputError("a jagged silhouette's scatter about its line must not be negative");
  }
  if (!(leafy_edge_share >= 0 && leafy_edge_share <= 1)) {
    throw InputError("the share of jagged silhouettes that makes a fit leaves must lie in [0, 1]");
  }
  if (sides_past_nearer_min_views < 0) {
    throw InputError(
        "the views a stem behind a nearer one shows its sides in must not be negative");
  }
  if (one_side_past_nearer_min_views < 0) {
    throw InputError(
        "the views a stem behind a nearer one shows its one side in must not be negative");
  }
  if (!(hidden_side_min_gain == 0 || hidden_side_min_gain >= 1)) {
    throw InputError("the gain a hidden side's widest width must reach must be 0 or at least 1");
  }
  if (!(hidden_side_min_seen_share >= 0 && hidden_side_min_seen_share <= 1)) {
    throw InputError(
        "the share of views a side toward a nearer stem must be seen in must lie in [0, 1]");
  }
  if (hidden_side_stand_min_stems < 1) {
    throw InputError("the stand's stems a hidden side's width needs must be at least 1");
  }
  if (!(narrow_fit_share >= 0 && narrow_fit_share <= 1)) {
    throw InputError(
        "the share of a part's width below which its cores are tried must lie in [0, 1]");
  }
  if (!(min_core_share >= 0 && min_core_share <= 1)) {
    throw InputError("the share of a part's width a core must reach must lie in [0, 1]");
  }
}

namespace {

// Stems where the silhouettes' votes meet (VoteStemCentres), most votes first, for
// RefineWithTangentRays to try where no listed stem stands.
std::vector<Stem> VotedStems(const MeasureOptions& o, const MeasureInput& in,
                             const GroundGrid& ground) {
  const SilhouetteVoteOptions& vo = o.votes;
  if (vo.max_candidates == 0) return {};
  std::vector<cv::Mat> gray(in.bgr->size());
  for (size_t k = 0; k < gray.size(); ++k) {
    if (!(*in.bgr)[k].empty()) cv::cvtColor((*in.bgr)[k], gray[k], cv::COLOR_BGR2GRAY);
  }
  const std::vector<SilhouetteRay> rays = FindSilhouetteRays(vo, *in.camera, *in.keyframes, gray);
  const std::vector<VoteCandidate> peaks = VoteStemCentres(vo, rays, o.stems.search_radius_m);
  std::vector<Stem> stems;
  for (const VoteCandidate& c : peaks) {
    spdlog::debug("stems: silhouettes meet at ({:.2f}, {:.2f}) r {:.3f}: {} votes", c.centre_xy.x(),
                  c.centre_xy.y(), c.radius_m, c.votes);
    Stem s;
    s.centre_xy = c.centre_xy;
    s.dbh_m = s.dbh_slice_m = 2 * c.radius_m;
    s.ground_z_m = ground.UphillHeight(c.centre_xy.x(), c.centre_xy.y(), c.radius_m);
    s.floor_z_m = ground.FloorHeight(c.centre_xy.x(), c.centre_xy.y());
    s.face_range_m = c.centre_xy.norm() - c.radius_m;
    s.silhouette_votes = c.votes;
    stems.push_back(std::move(s));
  }
  spdlog::info("stems: {} silhouettes meet in {} places, {} of them no thinner than the DBH floor",
               rays.size(), peaks.size(), stems.size());
  return stems;
}

}  // namespace

MeasureResult MeasureTrees(const MeasureOptions& o, MeasureInput in) {
  o.Check();
  if (in.cloud == nullptr || in.camera == nullptr || in.keyframes == nullptr || in.bgr == nullptr) {
    throw ProcessingError("measuring trees needs the cloud, the camera, keyframes and images");
  }
  const GroundGrid ground(*in.cloud, o.stems.search_radius_m + 2.0, o.ground);
  StemsResult sr = DetectStems(o.stems, *in.cloud, ground, in.depth_focal_px);
  std::vector<Stem> larger_only;
  if (in.coarse_cloud != nullptr && !in.coarse_cloud->empty()) {
    // The coarse points only give a second start to parts that come to nothing; the silhouettes
    // and the bark judge it like any other.
    std::vector<dense::CloudPoint> all = *in.cloud;
    all.insert(all.end(), in.coarse_cloud->begin(), in.coarse_cloud->end());
    // Its parts no stem as a whole stay so: the coarse points' cores are too rough to stand
    // for a stem the cloud's own cores missed.
    StemOptions more_options = o.stems;
    more_options.split_mixed_parts_into_cores = false;
    StemsResult more = DetectStems(more_options, all, ground, in.depth_focal_px);
    if (o.larger_cloud_only_max_rms_px > 0) {
      // Where the cloud has no part at all, the larger cloud's stems, vetoed or not: the coarse
      // points of a stem seen past a nearer one for a short turn often smear into its free space.
      std::vector<Stem> candidates = std::move(more.vetoed);
      candidates.insert(candidates.end(), more.stems.begin(), more.stems.end());
      // A core of a part no stem as a whole may be a shrub's: it hides nothing.
      std::vector<Stem> parts;
      std::ranges::copy_if(sr.stems, std::back_inserter(parts),
                           [](const Stem& s) { return !s.mixed_part_core; });
      larger_only = StemsAwayFrom(candidates, o.larger_cloud_part_gap_m, parts);
      sr.larger_cloud_only = static_cast<int>(larger_only.size());
    }
    sr.larger_cloud_parts =
        AttachLargerCloudParts(std::move(more.stems), o.larger_cloud_part_gap_m, &sr.stems);
  }
  std::vector<Stem> voted = VotedStems(o, in, ground);
  sr.silhouette_votes = static_cast<int>(voted.size());
  // The silhouettes are found at the video's resolution where it was given.
  const double silhouette_focal_px =
      in.camera->fx * (in.gray_full.empty() || in.gray_full[0].empty()
                           ? 1.0
                           : static_cast<double>(in.gray_full[0].cols) / in.camera->width);
  // The cloud's rays at a fitted circle, for stems without a part of their own.
  const std::vector<const dense::CloudPoint*> band = BandPoints(o.stems, *in.cloud, ground);
  auto on_cloud_surface = [&](const Eigen::Vector2d& centre, double radius_m) {
    int hits = 0;
    const double through = PassThroughRatio(band, centre, radius_m, &hits);
    return hits >= o.stems.min_points && through <= o.fit_on_cloud_max_pass_through;
  };
  RefineWithTangentRays(o, *in.camera, *in.keyframes, std::move(in.gray_full), *in.bgr, &sr.stems,
                        std::move(larger_only), std::move(voted),
                        o.fit_on_cloud_max_pass_through > 0 ? on_cloud_surface : CloudSurfaceAt());
  WidthsFromStand(o, &sr.stems);
  const size_t below =
      std::erase_if(sr.stems, [&](const Stem& s) { return 100 * s.dbh_m < o.min_dbh_cm; });
  if (below > 0) spdlog::info("stems: {} below {:.0f} cm DBH left out", below, o.min_dbh_cm);
  // Nearest first (docs/output-format.md's tree_id): fits move stems, and stems found late join.
  std::ranges::stable_sort(sr.stems, NearerTheCentre);
  for (Stem& s : sr.stems) {
    s.dbh_sd_m = DbhSd(o.uncertainty, s, s.centre_xy.norm() / silhouette_focal_px);
    s.confidence = DetectionConfidence(o.uncertainty, s);
  }
  MeasureResult r;
  r.summary = sr.Summary();
  r.summary["dbh_method"] = o.stems.dbh_method;
  // The camera circle's height above the ground under the tripod, as the cloud's ground gives it
  // (the plot frame's origin came from the sparse points' ground).
  double camera_z_m = 0.0;
  for (const StampedPose& k : *in.keyframes) camera_z_m += k.world_from_cam.translation.z();
  if (!in.keyframes->empty()) camera_z_m /= static_cast<double>(in.keyframes->size());
  if (std::isfinite(ground.AxisHeight())) {
    r.summary["ground_at_axis_m"] = ground.AxisHeight();
    r.summary["camera_height_m"] = camera_z_m - ground.AxisHeight();
  }
  const GroundGrid::Slope slope = ground.PlaneSlope(o.stems.search_radius_m);
  r.summary["ground_slope_deg"] = slope.slope_deg;
  r.summary["ground_downhill_azimuth_deg"] = slope.downhill_azimuth_deg;
  r.summary["ground_cells"] = ground.ground_cells();
  r.summary["measured_cells"] = ground.measured_cells();
  r.summary["below_min_dbh"] = below;
  r.trees = std::move(sr.stems);
  return r;
}

}  // namespace stemmap::stems
