#pragma once

// The silhouettes' verdicts on the cloud's parts: what each part becomes (a stem its silhouettes
// place, its cores, its cloud's stem, or nothing) and the tangent-ray refinement that asks them.
#include <Eigen/Core>
#include <array>
#include <functional>
#include <limits>
#include <opencv2/core.hpp>
#include <span>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/stems/bark_depth.h"
#include "stemmap/stems/measure.h"
#include "stemmap/stems/stems.h"
#include "stemmap/stems/tangent.h"

namespace stemmap::stems {

// What a silhouette fit does to a stem found in the cloud.
enum class SilhouetteVerdict {
  kUse,        // plausible: the fit places the stem (and gives the DBH with the tangent method)
  kKeepCloud,  // implausible: the cloud's estimate stays, flagged no_silhouette
  kDrop,       // implausible for a part that needed confirming: not a stem
};
// Metres one pixel spans at a stem `distance_m` from the plot centre (fx_px: the pictures' focal
// length), as the silhouettes' rms is judged: at least MeasureOptions::min_judged_px_m.
double JudgedPixelM(const MeasureOptions& o, double distance_m, double fx_px);

// Of a stem's breast-height points `slice_xy` (plot frame), seen from the plot centre: those at
// the range of the face of the circle (centre, radius_m), within max(5 cm, its radius) of it,
// and 1.3 to 4 of its angular half-widths past one of its outlines (the side with more), over those
// within its outline at any range; 0 where none lie within. A stem's bark going on past a circle's
// outline at the circle's face makes this a good part of one; past a real outline lies background.
double BarkPastOutlineShare(std::span<const Eigen::Vector2d> slice_xy,
                            const Eigen::Vector2d& centre, double radius_m);

// `px_m` is one pixel's footprint at the stem's distance (JudgedPixelM); `bark_lines_up`: the
// views warped through the fitted circle line up on its bark (BarkDepth::ok);
// `part_lines_up_on_bark`, asked only of a fit far narrower than the part
// (MeasureOptions::whole_in_wide_part_two_sided_share): whether the views line up on bark
// through the part's own circle, which then is one stem as wide as its points.
SilhouetteVerdict JudgeSilhouetteFit(const MeasureOptions& o, const Stem& stem,
                                     const TangentFit& fit, double px_m, bool bark_lines_up = false,
                                     const std::function<bool()>& part_lines_up_on_bark = {});

// The share of a fit's silhouettes whose bands scatter about their lines by more than
// MeasureOptions::leafy_edge_scatter_m and leafy_edge_scatter_px (px_m: metres a pixel spans at
// the stem); whether that share makes it a leaf clump's jagged outline, not a trunk's straight
// one (leafy_edge_share). Not for a fit straight behind a listed stem: one side's silhouettes
// run along that stem's outline and scatter with it, and whether the stem shows past it decides.
double JaggedSilhouetteShare(const MeasureOptions& o, const TangentFit& fit, double px_m);
bool LeafyOutline(const MeasureOptions& o, const TangentFit& fit, double px_m,
                  bool straight_behind_nearer = false);

// Whether a part whose silhouette fit failed is a stem all the same, kept on its cloud: its
// silhouettes were found on both sides in three views at least and a quarter of the views tried,
// or half of those where no nearer stem hid a side (a trunk's two edges; a shrub or sapling
// seldom shows them so), it was not weakly supported, and the views warped
// through its own cloud circle line up (`cloud_bark` ok and not at the end of its search).
bool BarkConfirmsCloud(const Stem& part, const TangentFit& fit, const BarkDepth& cloud_bark);

// Drops the stems whose bark comes within `min_bark_gap_m` of another's (MeasureOptions): one
// whose width rests on one side or its cloud (one_sided, no_silhouette) before one measured on
// both sides, else the one whose fit moved farther from its points (Stem::fit_shift_m). Returns
// how many.
int DropStemsFittedTwice(double min_bark_gap_m, std::vector<Stem>* stems);

// A stem as its silhouettes judged it.
struct RefinedStem {
  SilhouetteVerdict verdict = SilhouetteVerdict::kDrop;
  Stem stem;
  // Both sides in a quarter of its views, on one circle to a couple of pixels, or, straight
  // behind a nearer stem, each side in views of its own (SidesSeenApart); whole: both sides in
  // half of them.
  bool clean = false;
  bool whole = false;
  // Whether the silhouettes' circle agrees with the cloud's width (within a fifth of it).
  bool agrees_with_cloud = false;
  // Both sides in at least three views, on one circle to larger_cloud_only_max_rms_px.
  bool sharp = false;
  // Straight behind a listed stem, each side in views of its own on one circle (SidesSeenApart).
  bool seen_apart = false;
  // Straight behind a listed stem, kept on its cloud where its sides showed one at a time
  // (ShowsSidesPastNearerStem).
  bool sides_past_nearer = false;
  // Its bark lines up on the fit, which shows both sides, on one circle to a couple of pixels,
  // in half the views where no nearer stem hid a side (TangentFit::open_views), some of the
  // views it was tried in having a side hidden so.
  bool whole_where_open = false;
  // A stem the silhouettes' votes alone gave, whose fit agrees with their circle
  // (FitAgreesWithVotes).
  bool agrees_with_votes = false;
  // The cloud's rays end on the fitted circle and few pass it (MeasureOptions::
  // fit_on_cloud_max_pass_through): its surface is there, whatever part the cloud made of it.
  // And its bark lines up on the fit, or too few pairs of views show it to say. Judged only for
  // a stem without a part of its own (AddStemsWithoutPart); a part's own surface is its part.
  bool on_cloud_surface = false;
};
struct PartOutcome {
  int fitted = 0;      // stems placed by their silhouettes
  int from_cores = 0;  // of which the part's dense cores (Stem::alternatives)
  int dropped = 0;     // parts that are no stem
};
// Whether `core` and `fit` overlap (two circles of one stem) and `core` shows both sides in a
// larger share of the views it was tried in (FitEvidence).
bool OutlinesTheStemInMoreViews(const Stem& core, const Stem& fit);
// Whether two of `cores` face the plot centre from ranges (Stem::face_range_m) farther apart than
// the wider one's width plus `max_depth_smear_m`: no one stem's face spans that in range.
bool CoresOneBehindAnother(double max_depth_smear_m, std::span<const Stem> cores);
// What one part of the cloud becomes, appended to `kept`: the stem its silhouettes fit, the stems
// its cores make, the stem of its cloud, or nothing. `refine` judges one stem by its silhouettes.
// A core of a part no stem as a whole (Stem::mixed_part_core) becomes a stem only where its
// silhouettes are clean, as any part's core.
PartOutcome ResolvePart(const MeasureOptions& o, Stem part,
                        const std::function<RefinedStem(Stem)>& refine, std::vector<Stem>* kept);

// A circle of no radius on the plot's axis: behind every camera on the arm, it hides nothing.
inline const Eigen::Vector3d kNoOccluder = Eigen::Vector3d::Zero();

// The stems that one part of the cloud became (`fitted`) replace that part's circle (x, y,
// radius) among the occluders that farther stems' edge searches stop at. A part that became
// nothing hides nothing, unless `unfitted_hides` (MeasureOptions::unfitted_parts_hide; never for
// a core of a part no stem as a whole, Stem::mixed_part_core: a shrub's or a sapling's, as often
// as not), which keeps its cloud circle. `leaves`: the circles of the leafy outlines its fits
// found (LeafyOutline): no stems, but they hide what lies behind them as their silhouettes show
// it, in the part's place where it became nothing else.
void PlaceFittedOccluders(std::span<const Stem> fitted, std::span<const Eigen::Vector3d> leaves,
                          size_t part, bool unfitted_hides,
                          std::vector<Eigen::Vector3d>* occluders);

// The larger cloud's stems alone (`candidates`, nearest first), each tried where its centre
// lies MeasureOptions::larger_cloud_part_gap_m clear of every stem of `kept`: listed (flagged
// silhouette_only, and added to the occluders) when `refine` uses its fit and finds it sharp,
// whole, or straight behind a listed stem with its sides seen apart (RefinedStem).
// Returns how many were listed.
int AddLargerCloudOnlyStems(const MeasureOptions& o, std::vector<Stem> candidates,
                            const std::function<RefinedStem(Stem)>& refine, std::vector<Stem>* kept,
                            std::vector<Eigen::Vector3d>* occluders);

// Where stems found without a part of the cloud are tried: a candidate whose circle (its centre
// alone, without candidate_radius) comes within gap_m of a kept stem's is that stem; at most
// max_tries candidates are fitted.
struct CandidateTries {
  double gap_m = 0.1;
  bool candidate_radius = false;
  int max_tries = std::numeric_limits<int>::max();
};
// AddLargerCloudOnlyStems with its own rules of where candidates are tried.
int AddStemsWithoutPart(const MeasureOptions& o, std::vector<Stem> candidates,
                        const CandidateTries& tries, const std::function<RefinedStem(Stem)>& refine,
                        std::vector<Stem>* kept, std::vector<Eigen::Vector3d>* occluders);

// Both silhouettes in at least three views, on one circle to under max_rms_px pixels rms
// (`px_m`: one pixel's footprint at the stem).
bool HasSharpSilhouettes(const TangentFit& fit, double max_rms_px, double px_m);

// Whether `centre` (plot frame) lies straight behind one of the `nearer` stems seen from the plot
// centre: farther than its far side and within its angular width.
bool InShadowOfNearerStem(std::span<const Stem> nearer, const Eigen::Vector2d& centre);

// Whether a fit straight behind a nearer stem shows each side in views of its own
// (SidesSeenApart), each clear of the nearer stems' outlines (`clear_side_views`,
// SideViewsClearOfNearerStems) in min_views_each_side of them: edges found along a nearer
// stem's outline are that stem's, and a smear of its points straight behind it gathers them
// from either end of the arm (`px_m`: one pixel's footprint at the stem).
bool SidesSeenApartPastNearer(const TangentOptions& o, const TangentFit& fit,
                              const std::array<int, 2>& clear_side_views, double px_m);

// Whether a fit rests on silhouettes of its stem's own, not on a nearer stem's edges (`px_m`: one
// pixel's footprint at the stem).
bool StandsOnItsOwnSilhouettes(const TangentOptions& o, const TangentFit& fit, double px_m);

// Whether, seen from the plot centre, the circle (centre, radius_m) lies behind one of the
// `nearer` stems and is no wider than it: the nearer stem's outline covers it but for a side at a
// time in the views from along the arm. (One wider shows both sides past it in the same views.)
bool NoWiderThanANearerStemItIsBehind(std::span<const Stem> nearer, const Eigen::Vector2d& centre,
                                      double radius_m);

// Whether a part straight behind a listed stem, with no fit that stands on its own silhouettes,
// is a stem the nearer one hides but for one side at a time: not weakly supported, its cloud's
// circle (radius_m) no wider than one of the `nearer` stems it is behind, and its sides showed
// where that circle predicts them (`side_views`, SideViewsAt) in at least
// MeasureOptions::sides_past_nearer_min_views views. A smear of the nearer stem's points shows
// none there: its predicted sides lie along the nearer stem's outline, where none is searched.
bool ShowsSidesPastNearerStem(const MeasureOptions& o, const Stem& part, double radius_m,
                              std::span<const Stem> nearer, const std::array<int, 2>& side_views);

// Whether `fit` shows one side only (the other in fewer than TangentOptions::min_views_each_side
// views), in at least min_views views, each clear of every nearer stem's outline
// (SideViewsClearOfNearerStems), on one circle within narrow_max_rms_px (px_m: metres a pixel
// spans at the stem); 0 views: never. The nearer stem hides the other side from every point of the
// arm; a smear of the nearer stem's points carries that stem's silhouettes, along its outline.
bool OneSideSeenPastNearer(const TangentOptions& o, const TangentViews& views,
                           const TangentFit& fit, double breast_z, double px_m, int min_views);

// A part straight behind a listed stem whose fit rests on one side per view, or which has none
// (`fit`): the fit FitSidesOnFace holds on the face its cloud saw replaces `fit` when its sides
// show apart (SidesSeenApart) and it is no wider, from the plot centre, than a nearer stem it is
// behind (one wider shows both sides past it in the same views); or when it shows one side only
// (OneSideSeenPastNearer, from one_side_min_views views; 0: never) and `one_side_may_stand` says
// so (asked only then). Not for a part on weak support, whose sliver of surface may be the
// nearer stem's smear. Returns whether it replaced `fit`.
bool HoldOnFaceBehindNearer(const Stem& part, double radius0, std::span<const Stem> nearer,
                            const TangentOptions& topt, const TangentViews& views, double breast_z,
                            double px_m, int one_side_min_views,
                            const std::function<bool()>& one_side_may_stand, TangentFit* fit);

// The tangent fit checked on the bark: its distance from the bark (returned), and a fit whose bark
// lines up at no distance (correlation under min_surface_ncc over enough pairs) or best at the end
// of the search (beyond it, likely) fails. `measured`, when given, is the bark already measured
// on the fit's circle.
BarkDepth CheckFitOnBark(const BarkDepthOptions& o, const TangentOptions& t,
                         const TangentViews& views, double breast_z, TangentFit* fit,
                         const BarkDepth* measured = nullptr);

// Whether a fit the bark check rejected (`bark`: its bark's comparison) stands on its outline
// (MeasureOptions::outline_over_bark_*): bark that lines up nowhere, not best at the end of the
// search, inside a whole, tight outline as wide as the cloud's points (`cloud_radius_m`) and
// where they are: its centre off the cloud's (`cloud_centre`) by at most that radius across the
// line of sight (a circle around one side of the stem and what stands beside it has an outline
// too, and no bark). Narrower than the cloud by its share and outline_over_bark_smear_m only
// where its face lies within StemOptions::max_depth_smear_m of the cloud's.
bool OutlineOutweighsPlainBark(const MeasureOptions& o, const TangentFit& fit,
                               const BarkDepth& bark, const Eigen::Vector2d& cloud_centre,
                               double cloud_radius_m, double px_m);

// Whether a fit has the bark to show for its width: true unless it is over
// MeasureOptions::wide_fit_scale times `cloud_radius_m` and its bark lines up to under
// wide_fit_min_bark_ncc, or over too few pairs to tell. With `cloud_behind_nearer` (the cloud's
// part lies straight behind a listed stem, InShadowOfNearerStem), too few pairs let it stand: the
// cloud saw a sliver of the stem past the nearer one, a width that bounds nothing, and the bark
// the same few views show.
bool WideFitLinesUpOnBark(const MeasureOptions& o, const TangentFit& fit, const BarkDepth& bark,
                          double cloud_radius_m, bool cloud_behind_nearer = false);

// The DBH of each stem a nearer one hides one side of (Stem::dbh_hidden_max_m > 0, set by
// RefineWithTangentRays): the mean of the other listed stems' DBH between its seen width and the
// widest it could be (MeasureOptions::hidden_side_stand_min_stems of them at least; else the
// middle of the two), flagged width_from_stand. The stand is the prior a forester has for a stem
// seen in part.
void WidthsFromStand(const MeasureOptions& o, std::vector<Stem>* stems);

// Runs the tangent-ray estimator on every stem. A plausible fit places the stem; with the tangent
// method it also gives the DBH. `gray_full`: the keyframes' luma at the video's resolution
// (blurred in place), or empty to use `bgr` at the working resolution. `larger_cloud_only`
// (nearest first) are tried after them where no listed stem stands, and listed on sharp
// silhouettes (MeasureOptions::larger_cloud_only_max_rms_px), flagged silhouette_only; `voted`
// (the silhouettes' votes, most first) after them on the same terms, clear of the listed stems
// by SilhouetteVoteOptions::min_gap_to_listed_m.
// Whether the cloud's surface stands on a circle (centre, radius_m) at breast height.
using CloudSurfaceAt = std::function<bool(const Eigen::Vector2d& centre, double radius_m)>;

void RefineWithTangentRays(const MeasureOptions& o, const PinholeCamera& bgr_camera,
                           const std::vector<StampedPose>& keyframes,
                           std::vector<cv::Mat> gray_full, const std::vector<cv::Mat>& bgr,
                           std::vector<Stem>* stems, std::vector<Stem> larger_cloud_only = {},
                           std::vector<Stem> voted = {},
                           const CloudSurfaceAt& on_cloud_surface = {});

}  // namespace stemmap::stems
