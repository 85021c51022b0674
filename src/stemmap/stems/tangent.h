#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"

namespace stemmap::stems {

// DBH from tangent rays: in every keyframe that sees the stem, its left and right silhouette
// edges at breast height are rays tangent to the stem's cross-section, so each gives one linear
// equation n . (p - c) = r in the centre p and radius r (n: the ray's horizontal normal toward
// the stem, c: the camera centre). The edges come from depth, not brightness: neighbouring
// keyframes warped through the stem's own surface line up on the stem and not on what lies
// behind, so the stem is the run of columns where they agree. Edges are found in bands of rows
// around breast height and joined by a robust line per side; images at the video's full
// resolution give the finest edges.
struct TangentOptions {
  // Neighbouring keyframes compared with each view: the nearest ones on either side from which
  // what lies 1.5 times as far as the stem moves this much against it, at most this many away.
  double background_parallax_px = 3.0;
  int max_neighbour_offset = 8;
  // Seen near, even the nearest neighbour moves the stem's surface by several pixels per
  // centimetre of depth, and a circle a little off misaligns its bark; so each column is also
  // compared through depths up to this many steps in front of and behind the circle, each step
  // moving the surface this many pixels, and keeps the depth it agrees best at. Only as far as
  // keeps what lies 1.5 times as far moving by twice background_parallax_px (so steps come only
  // where the neighbour's baseline exceeds what that parallax needs: within about a metre of the
  // camera). 0 steps: the circle's depth alone.
  int near_depth_steps = 4;
  double near_depth_step_px = 3.0;
  int rows_half = 4;  // rows averaged per band
  // Bands of rows within this height of breast height; each silhouette is a line through them.
  double band_half_height_m = 0.35;
  // At most this many bands above and below breast height: a near stem's bands, spread over that
  // height, still give each silhouette's line (a stem 2 m away would have 13 on each side).
  int max_bands_each_side = 8;
  double search_px = 8.0;     // beyond the predicted edges, at least
  double search_share = 0.8;  // and this share of the predicted half-width
  double min_contrast = 6.0;  // grey levels between stem and background disagreement
  // Below that, the brightness step between stem and background, if at least this (grey levels).
  double min_brightness_contrast = 12.0;
  // There, a brightness step is the silhouette only where the bark's texture (mean change down
  // the rows, grey levels) ends at it: where the stem's middle lines up and has at least this
  // many times the background's texture, and it goes on beyond the step lining up as well, the
  // silhouette is where it ends (a sunlit side as bright as a hazy sky). 0 (the default): the
  // step alone; on the simulator's plots, 2 also carried edges onto a stem standing just behind
  // (docs/benchmarks.md, "Tried and not kept").
  double plain_background_texture_ratio = 0.0;
  double min_bark_texture = 1.0;  // the stem's middle's texture that may show it (grey levels)
  double huber_m = 0.004;         // robust scale of the ray residuals
  // The starting centre (from the cloud) as a prior of this share of the stem's distance.
  double prior_share_of_distance = 0.05;
  int min_rays = 8;
  double max_sideways_m = 0.1;  // across the line of sight from the start (or its radius)
  // From the start in any direction, at most this, or this many times the centre prior's sigma
  // where that is more (MaxMoveFrom): farther, the fit found another stem. The cloud of a far
  // stem, smeared along the line of sight, misjudges its depth by more than half a metre.
  double max_move_m = 0.5;
  double max_move_prior_sigmas = 2.0;
  double occluder_min_gap_m = 0.5;  // nearer stems closer than this to the stem are itself
  int refits = 2;                   // edge search again around the refined circle
  // The search also starts from the stem's radius times these (the cloud sees part of a stem
  // that a nearer one hides, and its width is too small to find the far silhouette); the start
  // whose fit has the most two-sided views wins. Empty: only the given radius.
  std::vector<double> wide_start_scales = {1.6, 2.2};
  // A fit two-sided in most views is checked against one from radius0 times this (0: not), which
  // replaces it when as clean (two-sided in most views, rms no larger) and this much wider.
  double recheck_wider_scale = 1.6;
  double recheck_min_gain = 1.1;
  // Or when two-sided in as many views or more with an rms at most this much larger (px at the
  // stem): a fit that closed inside the stem on bark or a shadow's edge is no tighter than the
  // whole stem's by more than noise (and loses both sides where that edge fades), while a
  // circle too wide makes no edges outside the stem to hold it wide.
  double recheck_rms_slack_px = 0.25;
  // And from these, below 1: the cloud merged the stem with what stands close beside it (a
  // sapling, a shrub), and a start that wide takes their gaps for the stem's inside.
  std::vector<double> narrow_start_scales = {0.5};
  double narrow_max_rms_px = 1.2;  // ray rms (px at the stem) a narrower start's fit must keep
  // A start's fit the bark lines up on, two-sided in most of its views and tangent to one circle
  // to within this rms (px at the stem), replaces a chosen fit the bark does not line up on.
  double on_bark_max_rms_px = 2.0;
  // A start's fit around the chosen one, at least recheck_min_gain as wide and tangent to one
  // circle within on_bark_max_rms_px, replaces it where the bark of the rim between the two lines
  // up through the wider circle: the chosen one closed inside the stem (FitTangentRays). Only a
  // chosen fit at least rim_min_share of the wider one's radius: edges inside a stem lie near its
  // outline (at 54-80 % of its width where seen), and a circle under half a wider one whose rim
  // lines up is a sapling within its leafy crown, or within a shrub, as often (40-45 %).
  bool recheck_rim = true;
  double rim_min_share = 0.5;
  // Where the bark lines up nowhere on the chosen fit and on no narrower start's fit, a start's
  // fit tangent to one circle within at most this share of the chosen one's ray rms replaces it,
  // if the bark does not contradict it (lines up, or too little shows to tell) and it stands on
  // its own silhouettes (both sides in three views, or each side in min_views_each_side, within
  // narrow_max_rms_px). A stem just beside a nearer one on its bearing: a start moved sideways
  // takes the nearer stem's edge for its own in the views where that hides it, and its looser
  // fit, drawn towards the nearer stem, shows both sides in more views than the stem's own. 0:
  // off.
  double tighter_rms_share = 0.5;
  double narrow_min_share = 0.35;  // of radius0: the narrowest fit that can stand for the stem
  // And from the centre moved across the line of sight by these multiples of radius0 (each way):
  // stereo smears a stem's points onto what stands beside it, so the cloud can place a thin stem
  // a width to the side, where the start's edges are its own and its neighbour's. Such a fit must
  // be two-sided in most views and is held to the narrower start's bounds.
  std::vector<double> sideways_start_shifts = {1.0, 2.0};
  // Each start finds some silhouettes right and some on what stands beside the stem; the
  // silhouettes of all starts are pooled and one circle fitted robustly. That circle replaces the
  // chosen start's when it is tangent to at least this many more of them, to within the narrower
  // start's rms.
  int pooled_min_extra_rays = 3;
  // A stem mostly hidden behind a nearer one shows both sides in only a few views. When no start
  // gave a fit with both sides in at least this many views, the start whose fit has the most
  // (at least this many, on one circle to within the narrower start's rms) stands, pooled with
  // the other starts' silhouettes. 0: off. Such a fit is no narrower than this share of the
  // cloud's width: the stereo pairs see a sliver of a hidden stem, never more than all of it.
  int few_views_min_two_sided = 3;
  double few_views_min_share = 0.9;
  // Such a fit is searched again from its own circle (its start's rounds may end before it
  // settles) and replaced when as tight, on as many silhouettes (one fewer at most).
  bool settle_few_views = true;
  // A chosen fit whose last round still changed its radius by more than this share of it has
  // not settled (a cloud smeared over what stands beside a thin stem starts the search far
  // outside it, and each round finds edges only part of the way in): it is searched again from
  // its own circle and replaced when the new circle is as tight, on as many silhouettes and both
  // sides in as many views. 0: off.
  double settle_min_change_share = 0.03;
  // A stem straight behind a nearer one may show its left side only from one end of the arm and
  // its right side only from the other, never both at once. Silhouettes of each side in at
  // least this many views, on one circle to within the narrower start's rms, bound its width
  // from both sides as two-sided views do (SidesSeenApart). 0: off.
  int min_views_each_side = 4;
  // Such a stem's fit from sides seen apart slides along the line of sight (nearer and narrower,
  // farther and wider: one side per view fixes its angular width, not its range). FitSidesOnFace
  // holds the range of the face its cloud saw (Stem::face_range_m) to within this (m); its width
  // moves by this times the stem's angular half-width (a few mm for a 5-cm slip). 0: off.
  double face_sigma_m = 0.05;
  // Its starts grow from the cloud's width by this factor, up to the widest stem the nearer one
  // can hide (the cloud may have seen a sliver; a start far inside the outline finds nothing).
  double face_start_growth = 1.5;
  // The largest radius, as a multiple of radius0, that a fit from these starts may reach:
  // a little beyond the widest (a fit grows from its start), and 2.5 without wide starts.
  // The centre prior's sigma for a start at centre0 (CentrePrior::sigma_m).
  double PriorSigmaAt(const Eigen::Vector2d& centre0) const {
    return prior_share_of_distance * centre0.norm() + 0.05;
  }
  // How far a fit may move from a start at centre0.
  double MaxMoveFrom(const Eigen::Vector2d& centre0) const {
    return std::max(max_move_m, max_move_prior_sigmas * PriorSigmaAt(centre0));
  }
  double WidestFitScale() const {
    const double widest =
        wide_start_scales.empty() ? 0.0 : *std::ranges::max_element(wide_start_scales);
    return 1.25 * std::max(2.0, widest);
  }
  bool refine_on_brightness = true;  // move each edge onto the nearby brightness step
  // Gaussian blur of the images (px of the images used) before they are compared: resampling a
  // neighbour softens sharp bark, which would read as disagreement inside a well-lit stem.
  double blur_sigma_px = 1.0;
  void Check() const;

  // The pixel sizes above are for a 960-px wide working image; the same for images `s` times as
  // large.
  TangentOptions ForImageScale(double s) const {
    TangentOptions t = *this;
    t.rows_half = std::max(1, static_cast<int>(std::lround(rows_half * s)));
    t.search_px = search_px * s;
    return t;
  }
};

// The options as saved next to the outputs (pixel sizes for a 960-px wide working image).
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    TangentOptions, background_parallax_px, max_neighbour_offset, near_depth_steps,
    near_depth_step_px, rows_half, band_half_height_m, max_bands_each_side, search_px, search_share,
    min_contrast, min_brightness_contrast, plain_background_texture_ratio, min_bark_texture,
    huber_m, prior_share_of_distance, min_rays, max_sideways_m, max_move_m, max_move_prior_sigmas,
    occluder_min_gap_m, refits, wide_start_scales, recheck_wider_scale, recheck_min_gain,
    recheck_rms_slack_px, narrow_start_scales, narrow_max_rms_px, narrow_min_share,
    on_bark_max_rms_px, recheck_rim, rim_min_share, tighter_rms_share, sideways_start_shifts,
    pooled_min_extra_rays, few_views_min_two_sided, few_views_min_share, settle_few_views,
    settle_min_change_share, min_views_each_side, face_sigma_m, face_start_growth,
    refine_on_brightness, blur_sigma_px)

struct TangentViews {
  const PinholeCamera* camera = nullptr;                // of the images
  const std::vector<StampedPose>* keyframes = nullptr;  // plot frame
  const std::vector<cv::Mat>* gray = nullptr;           // CV_8U per keyframe (empty: missing)
  // Other stems (x, y, radius; plot frame): the edge search stops at a nearer one's silhouette,
  // and a side it covers, or leaves too little of to measure, is not used.
  const std::vector<Eigen::Vector3d>* occluders = nullptr;
};

struct TangentFit {
  bool ok = false;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius_m = 0.0, radius_sd_m = 0.0, rms_m = 0.0;
  int rays = 0, views = 0;
  int tried_views = 0;         // keyframes that should see the stem
  int hidden_sides = 0;        // silhouette sides (two a view) left out beside a nearer stem
  int open_views = 0;          // tried views where no nearer stem hid a side
  int two_sided_views = 0;     // views that gave both silhouettes
  double arc_deg = 0.0;        // spread of the viewing directions used
  double last_change_m = 0.0;  // how much the last round changed the radius (m)
  // The silhouettes of the last round: one ray each (keyframe, side 0 left / 1 right, the ray's
  // normal toward the stem, the camera centre, the heading from the stem to the camera).
  struct Ray {
    int keyframe = 0, side = 0;
    Eigen::Vector2d normal = Eigen::Vector2d::Zero(), origin = Eigen::Vector2d::Zero();
    double heading = 0;
    // How far the silhouette's bands scatter about its line (robust, metres at the stem): a
    // trunk's outline is straight over the bands, a leaf clump's jagged.
    double edge_scatter_m = 0;
  };
  std::vector<Ray> silhouettes;
  // The share of its silhouettes (of `side` alone, where not -1) whose edge_scatter_m exceeds
  // `scatter_m` (0 without any).
  double JaggedShare(double scatter_m, int side = -1) const;
  // The views that gave the silhouette of `side` (0 left, 1 right) in the last round.
  int SideViews(int side) const;
};

// Whether a fit shows each side of its stem in at least min_views_each_side views (in the same
// views or not) on one circle to within narrow_max_rms_px (px_m: metres a pixel spans at the
// stem): the left and right silhouettes, each tangent to it across views, bound its width from
// both sides, with no nearer stem's edge among them (those fan out and are tangent to no one
// circle behind it). Its depth along the line of sight is held less firmly than by two-sided
// views; its width, by the angle between the two sides' rays, far more.
bool SidesSeenApart(const TangentOptions& o, const TangentFit& fit, double px_m);

// Where the circle (c, r) predicts its silhouettes at breast height, how many views show each
// side (image left = 0) as a clean edge line, without fitting a circle to them: the test of a
// stem that nearer stems let show one side at a time. Sides a nearer stem's outline reaches
// (`views.occluders`) are not searched.
std::array<int, 2> SideViewsAt(const TangentOptions& o, const TangentViews& views,
                               const Eigen::Vector2d& c, double r, double breast_z);

// A stem straight behind a nearer one, which shows one side per view: the circle tangent to its
// silhouettes whose face (its nearest point to the plot centre) lies face_range_m out on the
// bearing of centre0, within TangentOptions::face_sigma_m. Started at radius0 and at growing
// multiples of it (face_start_growth) up to max_radius_m (the cloud sees a sliver of such a
// stem: its width is a lower bound); the fit with the most views of its rarer side, then the most
// rays, is returned (not ok where none fits, or face_sigma_m is 0). Whether it stands is
// SidesSeenApart's to say.
TangentFit FitSidesOnFace(const TangentOptions& o, const TangentViews& views,
                          const Eigen::Vector2d& centre0, double radius0, double max_radius_m,
                          double face_range_m, double breast_z);

// How many views gave each side's silhouette (0 image left, 1 right) of `fit` clear of every
// nearer stem's outline (`views.occluders`) by more than the edge search's margin for a side to
// show (three guards, WindowBesideOccluders): an edge found at a nearer stem's outline may be
// that stem's, and a side seen only there did not measure the stem.
std::array<int, 2> SideViewsClearOfNearerStems(const TangentOptions& o, const TangentViews& views,
                                               const TangentFit& fit, double breast_z);

// How many views that should see the stem (centre, radius_m) would show its side `side` (0 image
// left / 1 right) clear of nearer stems (`views.occluders`) and the picture's borders, by the
// edge search's guard. Geometry alone.
int ViewsShowingSide(const TangentOptions& o, const TangentViews& views,
                     const Eigen::Vector2d& centre, double radius_m, int side, double breast_z);

// The centre of the stem (centre, radius_m) grown to `grown_radius_m` toward its side
// `hidden_side` (0 image left / 1 right, seen from the plot centre) with its face (nearest point
// to the plot centre) and its other side held where they are.
Eigen::Vector2d GrownHoldingFace(const Eigen::Vector2d& centre, double radius_m, int hidden_side,
                                 double grown_radius_m);

// For a stem a nearer one hides one side of (`hidden_side`, 0 image left / 1 right) in most
// views: the widest circle that keeps that side out of sight. The circle (centre, radius_m) is
// grown, its face (nearest point to the plot centre) and its other side held where they are,
// until the hidden side would show past a nearer stem's far outline (`views.occluders`), in the
// open within the picture, in more than one view that should see the stem (one such view may have
// missed an edge), until no view would hide it, or until it would reach into another stem; at
// most max_radius_m. radius_m where nothing hides that side. Geometry alone: no picture is read.
// The width seen bounds the radius from below; this, from above.
double WidestRadiusWithSideHidden(const TangentOptions& o, const TangentViews& views,
                                  const Eigen::Vector2d& centre, double radius_m, int hidden_side,
                                  double breast_z, double max_radius_m);

// One circle for the silhouettes of several fits of one stem (each silhouette once): reweighted
// from each fit's circle in turn, the circle tangent to the most silhouettes. `pooled` is `chosen`
// with that circle, its spread and the silhouettes on it; false when fewer than min_rays are.
bool FitPooledSilhouettes(const TangentOptions& o, const std::vector<const TangentFit*>& fits,
                          const TangentFit& chosen, TangentFit* pooled);

// For a stem mostly hidden behind a nearer one: among the fits of all starts, the one with both
// sides in the most views (at least few_views_min_two_sided) on one circle to within the narrower
// start's rms (px_m: metres a pixel spans at the stem), no narrower than few_views_min_share of
// radius0 and within the sideways starts' reach (its own silhouettes only: pooled with the
// others', a short arc's poorly held depth lets a far-off pair of edges drag it). None when no
// start gives one.
// `accept`, when given, must accept the fit too (the best it accepts stands).
std::optional<TangentFit> FitSeenInFewViews(
    const TangentOptions& o, const std::vector<const TangentFit*>& ok_fits,
    const Eigen::Vector2d& centre0, double radius0, double px_m,
    const std::function<bool(const TangentFit&)>& accept = {});

// Whether `settled`, searched again from the circle of `chosen` (a fit whose last round still
// changed its radius), replaces it: as tight, on as many silhouettes and two-sided views, and no
// narrower than a fit that can stand for the stem (a share of radius0, the cloud's radius).
bool SettledChosenFitReplaces(const TangentOptions& o, const TangentFit& chosen,
                              const TangentFit& settled, double radius0);

// Whether `settled`, searched again from the circle of `few` (a FitSeenInFewViews fit), replaces
// it: as tight, on as many silhouettes and two-sided views (one fewer at most), within the same
// bounds on its radius and place.
bool SettledFitReplaces(const TangentOptions& o, const TangentFit& few, const TangentFit& settled,
                        const Eigen::Vector2d& centre0, double radius0);

// Blurs the keyframe images in place as `o.blur_sigma_px` says (before FitTangentRays).
void PrepareTangentImages(const TangentOptions& o, std::vector<cv::Mat>* gray);

// Whether a fit from the wider recheck start replaces a fit two-sided in most views: two-sided in
// most of its own views, as tight (or two-sided in as many views within recheck_rms_slack_px; px_m:
// metres a pixel spans at the stem), wider by recheck_min_gain, within the widest scale of
// radius0 and beside the fit by less than max_sideways_m across the line of sight.
bool WiderRecheckWins(const TangentOptions& o, const TangentFit& fit, const TangentFit& wider,
                      const Eigen::Vector2d& centre0, double radius0, double px_m);

// What the bark says of a fit's circle (bark_depth.h measures it): views warped through it line
// up at one distance; they line up at none (nor within the search), so the circle's inside is no
// one stem's bark; or it cannot tell (too few views show it, or it lines up alike at every
// distance tried).
enum class BarkVerdict { kLinesUp, kLinesUpNowhere, kSaysNothing };

// Among the starts' fits `tried` narrower than `chosen`, the one with both sides in the most
// views (in most of its own, within on_bark_max_rms_px of one circle; px_m: metres a pixel spans
// at the stem, and no narrower than narrow_min_share or wider than the widest start of radius0)
// whose bark lines up. None when no such fit is accepted.
std::optional<TangentFit> FitTheBarkLinesUpOn(
    const TangentOptions& o, const std::vector<TangentFit>& tried, const TangentFit& chosen,
    double radius0, double px_m, const std::function<BarkVerdict(const TangentFit&)>& bark);

// Among the starts' fits `tried`, those tangent to one circle within tighter_rms_share of
// `chosen`'s ray rms that stand on their own silhouettes (both sides in three views, or each side
// in min_views_each_side; within narrow_max_rms_px; px_m: metres a pixel spans at the stem; no
// narrower than narrow_min_share or wider than the widest start of radius0), the first the bark
// lines up on, or else the first it says nothing of (`bark`), by most two-sided views, then the
// tightest. None when the bark lines up nowhere on each.
std::optional<TangentFit> TighterFitTheBarkAllows(
    const TangentOptions& o, const std::vector<TangentFit>& tried, const TangentFit& chosen,
    double radius0, double px_m, const std::function<BarkVerdict(const TangentFit&)>& bark);

// Among the starts' fits `tried` around `chosen` (at least recheck_min_gain as wide and at most
// 1 / rim_min_share, within the widest start's reach of radius0, offset from it across the line of
// sight by no more than the difference of their radii and a pixel, and tangent to one circle within
// on_bark_max_rms_px; px_m: metres a pixel spans at the stem), the one with the most silhouettes
// whose rim beyond `chosen` the bark says lines up (`rim`: the wider fit and the narrower radius).
// None when none does.
std::optional<TangentFit> FitWhoseRimIsBark(
    const TangentOptions& o, const std::vector<TangentFit>& tried, const TangentFit& chosen,
    double radius0, double px_m, const std::function<BarkVerdict(const TangentFit&, double)>& rim);

// Starts from a stem estimate (centre, radius) and the height of breast height in the plot frame.
// The circle found stays within max_sideways_m (or the radius a start supposes, radius0 or a wide
// one) of centre0 across the line of sight and within MaxMoveFrom(centre0) of it.
// `accept`, when given, judges a fit on other evidence (e.g. the bark, bark_depth.h): a stem seen
// two-sided in few views takes the best of the starts' fits that it accepts (FitSeenInFewViews).
// `bark`, when given, says what the bark makes of a fit's circle: a chosen fit it lines up nowhere
// on gives way to FitTheBarkLinesUpOn, or else to TighterFitTheBarkAllows. `rim`, when given, says
// what the bark makes of the rim of a circle beyond a narrower radius (bark_depth.h,
// MeasureRimBark): a fit around the chosen one whose rim lines up replaces it (FitWhoseRimIsBark,
// recheck_rim).
TangentFit FitTangentRays(const TangentOptions& o, const TangentViews& views,
                          const Eigen::Vector2d& centre0, double radius0, double breast_z,
                          const std::function<bool(const TangentFit&)>& accept = {},
                          const std::function<BarkVerdict(const TangentFit&)>& bark = {},
                          const std::function<BarkVerdict(const TangentFit&, double)>& rim = {});

// Where a disagreement profile first rises above tau going from `start` in direction dir (+1 or
// -1) and stays above it on average over the next `run` samples: bark that the warp misaligns on
// a near stem makes short spikes inside it, what lies behind a long run. The crossing is
// interpolated between samples. False when the profile never does.
bool FirstSustainedCrossing(const std::vector<double>& profile, int start, int dir, double tau,
                            int run, double* x);

// Column at row y0 of a silhouette line through edge points (y, x) found in bands of rows: a
// trunk's silhouette is straight over a few decimetres (taper and lean are smooth), so a robust
// line (Theil-Sen start, then least squares on the points within 3 MADs) averages the bands'
// noise and ignores a band that caught a neighbour or a furrow. False with fewer than min_points
// on the line or a line leaning more than 0.15 px/px. `scatter_px` (if given): the bands' robust
// scatter about the line (1.4826 times their median distance from it, px).
bool FitEdgeLine(const std::vector<double>& y, const std::vector<double>& x, double y0,
                 int min_points, double* x_at_y0, double* scatter_px = nullptr);

// A soft prior on the centre (e.g. the cloud's), for views that barely fix the stem's depth:
// rays from a short arc of the arm leave the circle free to slide along the line of sight.
struct CentrePrior {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double sigma_m = 1.0;        // of the prior, in each direction
  double ray_sigma_m = 0.005;  // expected ray residual, which sets the prior's relative weight
  // A prior on the radius too, when radius_sigma_m > 0: silhouettes of one side only fix where
  // the stem's side is, not how wide it is.
  double radius_m = 0.0, radius_sigma_m = 0.0;
  // A prior on the range of the face the cameras see, when face_sigma_m > 0: the circle's
  // nearest point to the plot centre along the unit bearing `face_bearing` lies face_range_m
  // out. Rays from one side per view leave the stem free to slide along the line of sight
  // (nearer and narrower, farther and wider); the face's range holds it.
  Eigen::Vector2d face_bearing = Eigen::Vector2d::UnitX();
  double face_range_m = 0.0, face_sigma_m = 0.0;
};

// Least squares circle tangent to horizontal lines n_i . (p - c_i) = r, weighted by Huber and,
// with `redescend`, then by Cauchy (scale 2 huber_m) so that a few rays far off do not move it.
// Returns false when the system is degenerate.
bool SolveTangentCircle(const std::vector<Eigen::Vector2d>& normals,
                        const std::vector<Eigen::Vector2d>& origins, double huber_m,
                        Eigen::Vector2d* centre, double* radius, double* radius_sd, double* rms_m,
                        std::vector<double>* weights, const CentrePrior* prior = nullptr,
                        bool redescend = true);

}  // namespace stemmap::stems
