#pragma once

// Stem candidates from the images alone, where the cloud has no points on a stem (a stem seen
// between leaves or past a nearer stem for part of the turn): every straight vertical edge at
// breast height in every keyframe whose two sides lie at different depths is a silhouette, a
// ray tangent to something nearer on one side. Its tangent line, moved by a radius toward that
// side, passes through the centre of a stem of that radius; near the distance the silhouette's
// parallax gives, each silhouette votes for those centres in the plot plane, and a stem's
// silhouettes from many arm positions meet at its centre. The silhouettes' fit (tangent.h) and
// the bark judge each candidate as they judge a part of the cloud.
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"

namespace stemmap::stems {

struct SilhouetteVoteOptions {
  // The most-voted candidates fitted (each costs a fit) where no listed stem's circle comes
  // within min_gap_to_listed_m of theirs (m); 0: off.
  int max_candidates = 12;
  double min_gap_to_listed_m = 0.3;
  double cell_m = 0.05;  // the vote grid's cell in the plot plane
  // Radii voted for: from the thinnest stem listed to a thick one, in steps under half a cell
  // (a tangent line moved by a radius one step off still crosses the centre's cell).
  double min_radius_m = 0.04;
  double max_radius_m = 0.45;
  double radius_step_m = 0.025;
  double min_range_m = 1.2;  // candidates this far from the plot centre at least (m)
  // The edges are looked for in a strip of this many rows spanning this height each side of
  // the camera, at strip_range_m out: a trunk's silhouette is straight across it, a leaf clump's
  // is not.
  int strip_rows = 16;
  double strip_half_height_m = 0.3;
  double strip_range_m = 5.0;
  // An edge: grey levels stepped across two pixels, on average over the strip's rows, and that
  // average at least this share of the rows' mean absolute step (the step has one sign and one
  // column all the way up: a straight vertical edge).
  double min_edge_step = 10.0;
  double min_edge_straightness = 0.7;
  // The sides' depth: each side's patch (columns wide, beside a guard of columns at the edge)
  // is matched in the keyframes this far along the arm on either side (m); the near side's
  // match must correlate to at least min_side_ncc, and the two sides' parallax differ by at
  // least min_parallax_step_px (a texture's edge moves with its surface on both sides). A side
  // this flat (grey levels' SD) is far: sky, or a far canopy's shade.
  double neighbour_baseline_m = 0.12;
  // Where neither of those tells the sides apart, the keyframes this far along (m; 0: none): a
  // stem seen past a nearer one shows only between that stem and the picture's border, over a
  // shorter stretch of the arm than the baseline, so both neighbours lose it.
  double short_baseline_m = 0.04;
  int side_patch_px = 7;
  int side_guard_px = 2;
  double max_parallax_px = 60.0;
  double min_side_ncc = 0.7;
  double min_parallax_step_px = 1.5;
  double flat_side_sd = 2.0;
  // The parallax's uncertainty (px): each silhouette votes over the distances it allows, and at
  // least min_vote_span_m either side of its distance.
  double parallax_sd_px = 0.5;
  double min_vote_span_m = 0.15;
  // Candidates: at least this many silhouettes meet at the centre (from as many views, or both
  // sides of fewer), at least min_votes_each_side of them on either side of the stem, and two
  // candidates stand at least this far apart (m).
  int min_votes = 8;
  int min_votes_each_side = 3;
  // A cell of the vote grid is refined into a candidate from this many votes (no more than
  // min_votes): a stem seen in few views from a short stretch of the arm scatters its votes
  // over neighbouring cells along the line of sight, and meets min_votes only once refined.
  int min_cell_votes = 6;
  // A candidate stands on its silhouettes' fit (TangentFit, from the neighbours' disagreement,
  // not from brightness steps) where that fit agrees with the votes' circle: its radius within
  // this share of the votes' and this much more (m), its centre within the votes' radius (and a
  // cell), both sides in at least this many views. Two estimators from different edges meeting
  // on one circle: the bark need not line up (leaves hold still across it as bark does; a stem
  // seen past nearer stems shows too little of it). 0 views: off.
  double agree_radius_share = 0.2;
  double agree_radius_m = 0.005;
  int agree_min_two_sided_views = 3;
  // Or each side in at least this many views of its own, the fit on one circle to within 2 px
  // (the caller counts them, FitAgreesWithVotes): a stem just past a nearer one shows one side at
  // a time, from either end of the arm. 0: off.
  int agree_min_views_each_side = 4;
  double min_separation_m = 0.5;
  void Check() const;
};
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    SilhouetteVoteOptions, max_candidates, min_gap_to_listed_m, cell_m, min_radius_m, max_radius_m,
    radius_step_m, min_range_m, strip_rows, strip_half_height_m, strip_range_m, min_edge_step,
    min_edge_straightness, neighbour_baseline_m, short_baseline_m, side_patch_px, side_guard_px,
    max_parallax_px, min_side_ncc, min_parallax_step_px, flat_side_sd, parallax_sd_px,
    min_vote_span_m, min_votes, min_votes_each_side, min_cell_votes, min_separation_m,
    agree_radius_share, agree_radius_m, agree_min_two_sided_views, agree_min_views_each_side)

// A silhouette in the plot plane: the camera centre, the ray's azimuth, the side the nearer
// surface lies on (+1 left of the ray looking along it, -1 right) and the distance along the ray
// where its parallax puts that surface, with the range that parallax allows (m).
struct SilhouetteRay {
  Eigen::Vector2d origin_xy = Eigen::Vector2d::Zero();
  double azimuth_rad = 0.0;
  int near_side = 0;
  double distance_m = 0.0, min_distance_m = 0.0, max_distance_m = 0.0;
};

struct VoteCandidate {
  Eigen::Vector2d centre_xy = Eigen::Vector2d::Zero();
  double radius_m = 0.0;
  int votes = 0;
};

// Whether a fit of the silhouettes (centre, radius_m, two-sided in two_sided_views, each side in
// at least each_side_views views where its rays keep to one circle within 2 px, else 0) agrees
// with the votes' circle (vote_centre, vote_radius_m) as SilhouetteVoteOptions::agree_* says.
bool FitAgreesWithVotes(const SilhouetteVoteOptions& o, const Eigen::Vector2d& vote_centre,
                        double vote_radius_m, const Eigen::Vector2d& centre, double radius_m,
                        int two_sided_views, int each_side_views = 0);

// The silhouettes of every keyframe (gray: CV_8U per keyframe, empty where missing; camera: of
// those images; keyframes: plot frame, in the order of the turn).
std::vector<SilhouetteRay> FindSilhouetteRays(const SilhouetteVoteOptions& o,
                                              const PinholeCamera& camera,
                                              const std::vector<StampedPose>& keyframes,
                                              const std::vector<cv::Mat>& gray);

// The centres where silhouettes meet, within search_radius_m of the plot centre, most votes
// first (at most max_candidates).
std::vector<VoteCandidate> VoteStemCentres(const SilhouetteVoteOptions& o,
                                           const std::vector<SilhouetteRay>& rays,
                                           double search_radius_m);

}  // namespace stemmap::stems
