#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <nlohmann/json_fwd.hpp>
#include <vector>

#include "stemmap/stems/tangent.h"

namespace stemmap::stems {

// A stem's distance from its bark. The tangent rays fix a stem's bearing and apparent width well,
// but its distance only through the parallax of two edges across the arm's short arc, so a
// fraction of a pixel on the edges moves it by centimetres. The bark between the edges is a
// thousand pixels of texture: two keyframes a few decimetres apart, one warped onto the other
// through a circle of the fitted apparent width, line up on the bark only when the circle is at
// the right distance. The distance is searched along the line from the plot centre; the radius
// scales with it so that the circle keeps the silhouettes.
struct BarkDepthOptions {
  bool enabled = true;
  // Camera separation of the compared keyframes, at least: this, and this share of the stem's
  // distance (the bark's parallax against a distance error falls with the distance squared).
  double baseline_m = 0.45;
  double baseline_share = 0.07;
  // Where the bark is hidden or out of the picture that far, the farthest keyframe short of it
  // that shows the bark, down to this.
  double min_baseline_m = 0.25;
  double band_half_height_m = 0.1;  // rows within this height of breast height
  double inner_share = 0.6;         // middle share of the stem's width compared
  double search_m = 0.3;            // distances tried on either side of the tangent fit
  double step_m = 0.01;
  int max_pixels = 1200;            // compared per keyframe (a near stem's are subsampled)
  int min_pixels = 60;              // a view showing less bark is not used
  int min_pairs = 6;                // of keyframes
  double min_peak_ncc = 0.7;        // mean normalised correlation at the best distance
  double min_peak_contrast = 0.02;  // above the mean of the search's two ends
  // Below this correlation at every distance, with enough pairs compared, the circle's inside is
  // not one stem's bark: the fit caught two stems and the gap between them, a shrub, or a stem
  // and what lies behind it. Nor is it when the bark lines up best at the end of the search: the
  // silhouettes put the circle farther than search_m from the bark they enclose.
  double min_surface_ncc = 0.3;
  // Views whose every pair stays below min_surface_ncc show something in front of the bark (a
  // sapling's crown, leaves, a shrub) and are left out, when they are at most this share of the
  // views compared.
  double max_hidden_view_share = 0.34;
  // The rim of a circle beyond a narrower one inside it (MeasureRimBark): from this share of the
  // width beyond the narrower circle's outline out to rim_outer_share of the width (an outline's
  // own pixels mix the stem with what lies behind).
  double rim_gap_share = 0.03;
  double rim_outer_share = 0.95;
  void Check() const;
};

// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    BarkDepthOptions, enabled, baseline_m, baseline_share, min_baseline_m, band_half_height_m,
    inner_share, search_m, step_m, max_pixels, min_pixels, min_pairs, min_peak_ncc,
    min_peak_contrast, min_surface_ncc, max_hidden_view_share, rim_gap_share, rim_outer_share)

struct BarkDepth {
  bool ok = false;
  double shift_m = 0.0;  // along the line from the plot centre (+: farther)
  double scale = 1.0;    // of the radius, which keeps the silhouettes
  double peak_ncc = 0.0, end_ncc = 0.0;
  int pairs = 0;
  bool at_search_end = false;  // the bark lines up best at the end of the search, or beyond it
};

// Distance of the circle (centre, radius) at height breast_z, searched from the bark in the views
// (occluders: nearer stems, whose silhouettes must leave the bark free). `silhouettes` are the
// tangent options, for what counts as a nearer stem.
BarkDepth MeasureBarkDepth(const BarkDepthOptions& o, const TangentOptions& silhouettes,
                           const TangentViews& views, const Eigen::Vector2d& centre, double radius,
                           double breast_z);

// The bark of the rim of the circle (centre, radius) beyond a narrower circle of inner_radius
// inside it, measured as MeasureBarkDepth measures the middle. Where the narrower circle lies
// inside the stem, the rim is the stem's surface and lines up through the wider circle; where
// the narrower one is the stem's outline, the rim is what lies behind it, at another depth.
// Not measured (ok false, no pairs) where the rim is empty.
BarkDepth MeasureRimBark(const BarkDepthOptions& o, const TangentOptions& silhouettes,
                         const TangentViews& views, const Eigen::Vector2d& centre, double radius,
                         double inner_radius, double breast_z);

// What `bark` says of the circle it was measured on: it lines up (ok); it lines up nowhere (enough
// pairs compared, and below min_peak_ncc at every distance or best at the search's end); or it
// cannot tell.
BarkVerdict JudgeBark(const BarkDepthOptions& o, const BarkDepth& bark);

}  // namespace stemmap::stems
