#pragma once

// The tree list from the fused cloud and the keyframes: every stem and DBH decision of stemmap.
// The pipeline hands this layer the cloud and the images and takes the trees back.
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/dense/stereo.h"
#include "stemmap/stems/bark_depth.h"
#include "stemmap/stems/ground.h"
#include "stemmap/stems/silhouette_votes.h"
#include "stemmap/stems/stems.h"
#include "stemmap/stems/tangent.h"
#include "stemmap/stems/uncertainty.h"

namespace stemmap::stems {

struct MeasureOptions {
  StemOptions stems;            // the cloud's parts: band, support, lean, free space
  TangentOptions tangent;       // the silhouettes' fit
  BarkDepthOptions bark_depth;  // the fit's distance from the bark
  // Candidates from the images alone where neither cloud has a part: tried last, on the terms
  // of the larger cloud's stems alone (larger_cloud_only_max_rms_px and after it).
  SilhouetteVoteOptions votes;
  double min_dbh_cm = 7.0;  // stems thinner than this are not listed (a fit closed on a twig)
  // A sapling's leaves, or stereo's smear of a stem a few pixels wide, make its part wider than
  // the stem, and leaves hide its outline in most views. Where the silhouettes outline a stem
  // thinner than this (cm) inside such a part (narrower than it, down to
  // TangentOptions::narrow_min_share of it), both sides in three views on one circle to about a
  // pixel (tight_fit_rms_px), the fit places the sapling at its own width (left out under
  // min_dbh_cm); otherwise the part's width would stand for it, flagged no_silhouette. Whether
  // the bark lines up on that circle does not tell: on 26 simulated plots the 39 such outlines
  // were all of saplings (36), the bark lining up on 22 of them, and none lay inside a stem
  // (whose edges inside it lie at 54-80 % of its width). 0: off.
  double sapling_outline_max_dbh_cm = 7.0;
  // The terrain under the plot, out to the search radius and 2 m more.
  GroundOptions ground;
  UncertaintyOptions uncertainty;  // each stem's DBH SD and detection confidence
  // Drop cloud clusters whose silhouettes cannot be found in any view (a trunk shows two edges,
  // a leaf clump rarely does); false keeps them, flagged no_silhouette.
  bool require_silhouette = true;
  // Whether a part of the cloud that came to nothing (no stem kept, no leafy outline) still
  // hides farther stems from their edge searches, at its cloud's circle. Off: its silhouettes were
  // searched and not found, so nothing with an outline stands there; such parts are mostly depth
  // smear, points strewn along the line of sight in front of a farther stem, whose circle would
  // cover that stem's sides in every view and leave it no silhouettes at all.
  bool unfitted_parts_hide = false;
  // Unless the fit failed only on the bark (BarkConfirmsCloud): a stem standing in front of a
  // wider one shows its silhouettes against that one's bark, and a fit to them can settle on the
  // stem behind, where the bark does not line up; the part's own circle, where it does, stays.
  bool keep_bark_confirmed_cloud = true;
  // Silhouettes on one side only cannot tell how far the stem reaches on the other: such a fit
  // wider than this many times the cloud's width keeps the cloud's, unless its rays agree to
  // about a pixel and the cloud saw at least this radius (m) (a stem half hidden by a nearer one,
  // not a twig that one loose side widened).
  double one_sided_max_over_cloud = 1.1;
  double one_sided_min_cloud_radius_m = 0.075;
  // A part that silhouettes do not fit is replaced by its dense cores that they fit cleanly; when
  // the part is kept on its cloud (one stem, perhaps widened by a shrub), only by cores at least
  // this share of its width (a narrower one is a piece of the stem's bark), or by a narrower one
  // whose silhouettes show both sides in most of its views.
  double min_core_share = 0.6;
  // A smeared part whose silhouettes fit a stem under this share of its width may be stems one
  // behind another: its cores replace it when two or more of them fit cleanly on their own.
  double narrow_fit_share = 0.6;
  // So may a part whose cores face the centre from ranges farther apart than the wider core's
  // width plus the stem depth smear (StemOptions::max_depth_smear_m), whatever its fit's width:
  // one stem's face spans no more than its radius in range, and the fit of two stems nearly in
  // line (the nearer one's outer side and the farther one's) is about as wide as their part.
  bool try_cores_one_behind_another = true;
  // Two listed stems whose bark comes closer than this (m) at breast height are one stem fitted
  // twice (a fit that slid along its line of sight onto a nearer stem's silhouette): the one
  // whose fit moved farther from its points is dropped.
  double min_bark_gap_m = 0.02;
  // A stem found with the short-baseline points too within this (m) of a part of the cloud is
  // that part's second start (Stem::larger_cloud_part).
  double larger_cloud_part_gap_m = 0.1;
  // A stem of the larger cloud (vetoed by free space or not) with no part of the cloud within
  // that gap is tried last, and listed only on sharp silhouettes: both sides in at least three
  // views, on one circle to this many pixels rms (a nearer stem hides it for most of the turn;
  // clutter's edges are not tangent to one circle to a fraction of a pixel), or on whole ones:
  // both sides in at least half its views, on one circle to a couple of pixels (what a part's
  // core needs to stand alone). 0: not tried.
  double larger_cloud_only_max_rms_px = 0.5;
  // Or where its bark lines up and its silhouettes are whole in the views where no nearer stem
  // hid a side (RefinedStem::whole_where_open), at least min_dbh_cm wide: a stem a nearer one
  // hides for part of the turn, as BarkConfirmsCloud counts a part's views.
  bool larger_cloud_whole_where_open = true;
  // Or where the cloud's own rays end on its fitted circle: at least StemOptions::min_points of
  // them, and at most this share of those meeting it passing through (RefinedStem::
  // on_cloud_surface), its bark lining up on the fit or too little seen to say. A stem near the
  // camera, seen on its front arc alone, can give a part set back behind its bark that the
  // free-space veto rejects; the fit puts the circle on the bark. 0: not used.
  double fit_on_cloud_max_pass_through = 0.25;
  // A fit over this many times the cloud's radius found silhouettes beyond anything the cloud
  // saw (a wide start that closed on a sapling and the stem behind it, or on two neighbours; a
  // sapling's crown outlined around its few points): it stands only where the bark between them
  // lines up to at least this correlation over enough pairs (BarkDepthOptions::min_pairs). On
  // 28 stored runs (346 listed stems with a fit and a slice), the listed fits over 1.3 times the
  // slice's width whose bark correlated under 0.7 over six pairs or more were the runs' three
  // false stems (1.57-1.79 times, 0.40-0.67), the one true stem over 1.3 times lined up at 0.90,
  // and the true stems 1.23-1.24 times wide that lined up worse (0.55) lie under this scale.
  double wide_fit_scale = 1.4;
  double wide_fit_min_bark_ncc = 0.7;
  // A fit narrower than the cloud whose rays miss its circle by more than this rms (px at the
  // stem) does not outrank the cloud's width: its edges are not one stem's outline (bark
  // furrows, a shadow's border, a neighbour's edge in some views), and the points' width,
  // measured on the stem's surface, stands.
  double loose_fit_rms_px = 3.0;
  // A fit whose rays meet its circle to within this rms (px at the stem) agrees to about a pixel:
  // wider than the cloud, only such a fit with both sides in three views outranks the points.
  double tight_fit_rms_px = 1.2;
  // The silhouettes' rms is judged in pixels at the stem (tight_fit_rms_px and the rest), but a
  // pixel counts as at least this (m): a stem is round only to its section's out-of-roundness and
  // its bark's relief, so its tangent rays miss one circle by millimetres whatever the distance
  // (right fits on simulated plots: median 2.4 mm within 2.5 m of the plot centre, 90 % under
  // 3.2 mm, where 1.2 px at 1080p is 1.5 mm; 3.5 mm at 4.5-6 m). At 2.7 mm a tight fit
  // (tight_fit_rms_px) reaches 3.2 mm: nine right near fits in ten are tight, as a near part
  // with little surface needs its fit to be (at 2.5 mm a fifth of right near fits were not, and
  // such a stem, whole in half its views, was dropped). 0: pixels alone.
  double min_judged_px_m = 0.0027;
  // Within this many times the cloud's radius a wider fit counts as near the cloud's width even
  // when its rays agree less tightly than tight_fit_rms_px; beyond it such a fit caught edges
  // beside the stem (a farther stem's outline next to its side in some views, a sapling's) and
  // drifted outward with them, and the points' width stands.
  double loose_wider_max_over_cloud = 1.25;
  // A fit narrower than the cloud, down to TangentOptions::narrow_min_share of it, outranks the
  // cloud's width when both its sides show in half the views that tried it, on one circle to
  // about a pixel; where its bark lines up too (BarkDepth::ok), in this share of them.
  double narrower_on_bark_two_sided_share = 0.25;
  // Narrower still than TangentOptions::narrow_min_share of the cloud's width, a fit stands
  // where both its sides show in at least this share of the views that tried it (and three), on
  // one circle to about a pixel (tight_fit_rms_px), its bark lining up on it and the part's
  // points not going on past its outline (narrower_max_bark_past_outline), and the part's own
  // circle not lining up on bark: a stem whose part took in what stands beside or behind it (a
  // sapling's crown, a shrub) several times its width. 0: off.
  double whole_in_wide_part_two_sided_share = 0.9;
  // A circle inside a stem: a line on its bark (where sunlit bark meets shaded, a mark) and one
  // true outline can stay tangent to one narrower circle across the few degrees the arm sees a
  // far stem over, and its bark lines up on it too. The stem's own points give it away: they go
  // on past that circle's outline at the range of its face, where a real outline has background
  // behind it. A fit narrower than the points is not taken where the part's breast-height
  // points at its face's range, past one of its outlines, are this share or more of those within
  // its outline (BarkPastOutlineShare): the points' width stands. A circle at 0.4-0.7 of the
  // stem gives 1.1-0.37; leaves scattered around a stem as wide as 7 times it, up to twice its
  // points, under 0.2; fits at stems on 18 simulated plots, at most 0.12. Not for a smeared
  // part (its width is rough; the fit may be narrower) nor a sapling's outline
  // (sapling_outline_max_dbh_cm). 0: off.
  double narrower_max_bark_past_outline = 0.3;
  // Bark that correlates nowhere between views (leaves, or their shadows, across it from view to
  // view) does not outweigh a whole outline: a fit two-sided in at least this share of the views
  // that tried it, its rays on one circle to this many pixels (rms, px at the stem), its radius
  // within this share of the cloud's, stands where its bark correlates under
  // BarkDepthOptions::min_surface_ncc at every distance; not where the bark lines up best at the
  // end of the search (the circle lies away from the bark it encloses). The cloud's points of a
  // stem spread wider than it by stereo's smear, a few centimetres on a thin far stem, so an
  // outline may also be narrower than the cloud's share by outline_over_bark_smear_m of radius
  // (m), where its face lies within StemOptions::max_depth_smear_m of the cloud's (the smear
  // leaves the face where it is): on fresh plots, stems under 18 cm beyond 5 m had the cloud's
  // radius over theirs by 2.0 cm (median; 3.2 at the 80th percentile, 27 % and 55 % of it),
  // thicker ones by 0.4 / 1.8 cm.
  double outline_over_bark_two_sided_share = 0.5;
  double outline_over_bark_rms_px = 1.2;
  double outline_over_bark_cloud_share = 0.2;
  double outline_over_bark_smear_m = 0.03;
  // A part on weak support (little surface at breast height, a steep lean, a core of a part too
  // wide for one stem) is confirmed by silhouettes on both sides in three views on one circle to
  // about a pixel; or, where its bark lines up on the fit, by both sides in half the views that
  // tried it, on one circle to this many pixels (rms, px at the stem): a thick stem's outline
  // scatters more than a pixel, and neither leaves nor a shrub carry one view's bark onto the
  // next.
  double weak_on_bark_max_rms_px = 2.0;
  // A trunk's silhouette is a straight line over the bands of rows around breast height: its
  // bands stray from it by a fraction of a pixel (the edges' noise) and a few millimetres (the
  // bark's furrows). A leaf clump's outline is jagged at the scale of its leaves and holes,
  // centimetres. A silhouette whose bands scatter about its line by more than both of these
  // (robust; metres and pixels at the stem) is jagged, and a fit with at least leafy_edge_share
  // of its silhouettes jagged is leaves, a sapling's crown, not a stem: dropped whatever the
  // bark says (leaves hold still between views as bark does), it still hides what its outline
  // covers from farther stems' edge searches. A stem seen through leaves in some views keeps the
  // straight silhouettes of the others. 0: off.
  double leafy_edge_scatter_m = 0.01;
  double leafy_edge_scatter_px = 1.2;
  double leafy_edge_share = 0.67;
  // A part straight behind a listed stem, on firm support and no wider from the plot centre
  // than that stem, stands without a fit where its sides show, one at a time, where its cloud's
  // circle predicts them in at least this many views (sides within reach of the nearer stem's
  // outline are not searched): the nearer stem hides all but one side from each end of the arm
  // where the stem is in the picture, too few rays to fit a circle to. More than
  // TangentOptions::min_views_each_side, which asks both sides for that many. Kept on its cloud
  // (the larger cloud's where that is wider), flagged occluded. 0: off.
  int sides_past_nearer_min_views = 6;
  // A part straight behind a listed stem, whose cloud's circle shows no sides past it (above), and
  // whose fit held on the face its cloud saw shows one side only, stands on that side where the
  // side shows in at least this many views, each clear of every nearer stem's outline, on one
  // circle within TangentOptions::narrow_max_rms_px, and the other side hides where the circle
  // puts it in all but a few views that show it (OneSideSeenPastNearer): the nearer stem hides
  // that side from every point of the arm (a stem wider than it, at the edge of its outline seen
  // from the plot centre). Flagged occluded and one-sided. 0: off.
  int one_side_past_nearer_min_views = 8;
  // A stem a nearer one hides one side of in every view that could show it (both silhouettes in
  // fewer than three views, the hidden one in fewer than TangentOptions::min_views_each_side) is
  // as wide as its seen side and cloud give at least, and at most as wide as keeps that side
  // hidden (WidestRadiusWithSideHidden). Where the widest is at least hidden_side_min_gain times
  // the seen width, its DBH is the mean of the plot's other listed stems between the two (at
  // least hidden_side_stand_min_stems of them; else the middle of the two), flagged
  // width_from_stand, its SD half the way to the farther end. A width read from a sliver is a
  // lower bound, often a third of the stem. 0: off.
  double hidden_side_min_gain = 1.25;
  int hidden_side_stand_min_stems = 3;
  // The side toward the nearer stem measures the width only where it is found, clear of that
  // stem's outline, in at least this share of the views whose edge search would find it where
  // the width seen puts it (and in three at least): edges found in a few of them are the bark's
  // or the nearer stem's, and where the others show nothing the stem goes on behind (a 36-cm
  // stem read 16 cm from a near side found in 3 of 10 such views). 0: three views will do.
  double hidden_side_min_seen_share = 0.5;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    MeasureOptions, stems, tangent, bark_depth, votes, min_dbh_cm, sapling_outline_max_dbh_cm,
    ground, uncertainty, require_silhouette, unfitted_parts_hide, keep_bark_confirmed_cloud,
    one_sided_max_over_cloud, one_sided_min_cloud_radius_m, min_core_share, narrow_fit_share,
    try_cores_one_behind_another, min_bark_gap_m, larger_cloud_part_gap_m,
    larger_cloud_only_max_rms_px, larger_cloud_whole_where_open, fit_on_cloud_max_pass_through,
    wide_fit_scale, wide_fit_min_bark_ncc, loose_fit_rms_px, tight_fit_rms_px, min_judged_px_m,
    loose_wider_max_over_cloud, narrower_on_bark_two_sided_share,
    whole_in_wide_part_two_sided_share, narrower_max_bark_past_outline,
    outline_over_bark_two_sided_share, outline_over_bark_rms_px, outline_over_bark_cloud_share,
    outline_over_bark_smear_m, weak_on_bark_max_rms_px, leafy_edge_scatter_m, leafy_edge_scatter_px,
    leafy_edge_share, sides_past_nearer_min_views, one_side_past_nearer_min_views,
    hidden_side_min_gain, hidden_side_stand_min_stems, hidden_side_min_seen_share)

struct MeasureInput {
  const std::vector<dense::CloudPoint>* cloud = nullptr;  // plot frame, each point with its ray
  // The near pairs' coarse points beyond their depth limit (may be empty): a second start for
  // parts the cloud saw only in part, and stems it missed.
  const std::vector<dense::CloudPoint>* coarse_cloud = nullptr;
  double depth_focal_px = 0.0;            // the depth maps' focal length (DenseResult)
  const PinholeCamera* camera = nullptr;  // of `bgr`
  const std::vector<StampedPose>* keyframes = nullptr;  // plot frame
  const std::vector<cv::Mat>* bgr = nullptr;            // keyframe images (empty: missing)
  // The keyframes' luma at the video's resolution (empty: `bgr` is used), consumed.
  std::vector<cv::Mat> gray_full;
};

struct MeasureResult {
  std::vector<Stem> trees;  // nearest the plot centre first
  nlohmann::json summary;   // counts of each step
};

// The cloud's parts at breast height (and the coarse cloud's), each judged by its silhouettes
// and bark in the keyframes: the stems with their DBH, nearest first.
MeasureResult MeasureTrees(const MeasureOptions& options, MeasureInput input);

}  // namespace stemmap::stems
