#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "stemmap/core/enum_names.h"
#include "stemmap/dense/stereo.h"
#include "stemmap/stems/ground.h"

namespace stemmap::stems {

// How a stem's DBH is read: kTangent (rays tangent to the silhouettes, the slice width where no
// silhouette fits; the default, measured best), kSlice (the paper's robust width across the view)
// or kCircle (fitted to the slice). See docs/benchmarks-log.md. In files and on the command line:
// tangent, slice, circle.
enum class DbhMethod { kTangent, kSlice, kCircle };
inline constexpr EnumNames<DbhMethod, 3> kDbhMethodNames = {{{DbhMethod::kTangent, "tangent"},
                                                             {DbhMethod::kSlice, "slice"},
                                                             {DbhMethod::kCircle, "circle"}}};
inline std::string_view DbhMethodName(DbhMethod m) { return EnumName(kDbhMethodNames, m); }
STEMMAP_ENUM_JSON(DbhMethod, kDbhMethodNames, "DBH method")

struct StemOptions {
  double breast_height_m = 1.37;  // above the local ground at the stem
  double search_radius_m = 11.0;  // stems looked for this far from the centre
  double band_low_m = 0.9;        // detection band above the ground
  double band_high_m = 2.1;
  double grid_m = 0.02;  // occupancy grid of the band
  int min_cell_points = 2;
  bool split_wide_parts = false;  // re-split parts too wide for one stem on denser cells
  // Split parts too wide for one stem where their bearings from the centre leave a gap of
  // split_gap_m (across the line of sight), then where their ranges leave split_range_gap_m.
  bool split_by_bearing = true;
  // Points spread along the line of sight by more than the stem's width plus this are smeared
  // by depth noise: the stem is placed and sized by its width across the line of sight.
  double max_depth_smear_m = 0.3;
  double split_gap_m = 0.06;
  // A part may be stems one behind another that depth noise joined, or a stem and a sapling
  // beside it: its denser cores are kept as alternatives (Stem::alternatives), tried when no
  // silhouette fits the whole.
  bool split_parts_into_cores = true;
  double split_range_gap_m = 0.6;
  // A part no stem as a whole, too wide for one or leaning further than max_lean_deg (a stem
  // with a shrub beside it at one height, stems in a shrub, stems that understory joins), yields
  // its denser cores as stems on weak support: silhouettes must confirm them.
  bool split_mixed_parts_into_cores = true;
  // Where no density splits such a part in two, one denser core alone counts when it sheds at
  // least the rest of this share of the part's points (a shrub at one height).
  double mixed_part_lone_core_max_share = 0.67;
  int min_points = 25;
  // Breast-height slice points times the area one depth pixel covers at the stem's distance
  // (m², summed over the pairs that see it). Stereo points thin out with the square of the
  // distance, so a fixed count would favour near clutter and drop far stems; less than this is
  // too little surface for a stem (shrub twigs, noise).
  double min_slice_support_m2 = 0.075;
  // Parts with at least this share of it are kept as weak_support, for silhouettes to confirm.
  double weak_support_share = 0.25;
  double min_diameter_m = 0.05;
  double max_diameter_m = 1.2;
  double max_lean_deg = 15.0;
  // Parts leaning further than this (up to max_lean_deg) are stems only if two-sided
  // silhouettes confirm them (kept as weak_support): a trunk seldom leans so far at breast
  // height, the cloud of a shrub, a sapling or two things side by side often does.
  double confirm_lean_deg = 8.0;
  // The lean is measured between the centroids of the band's thirds (sub-slices) that hold the
  // stem's surface: at least lean_slice_min_points points near its circle and a share
  // lean_slice_min_share of the densest third's (a third with fewer holds only stray points, as
  // where a near stem's top is out of view).
  int lean_slice_min_points = 5;
  double lean_slice_min_share = 0.1;
  // A third's centre is the circle of the part's radius through its points where half of them lie
  // on it within this share of the radius, else their centroid: a near trunk shows each height on
  // another arc, whose centroids stand apart by most of its radius.
  double lean_circle_max_off_share = 0.25;
  double slice_half_m = 0.05;  // breast-height slice: ±5 cm (the paper's 0.1 m)
  // Rays through the stem over rays ending on it, above which it is no stem. Stereo smears a thin
  // stem's points beside it, and rays to what stands behind graze its part: real stems' parts
  // reach 40-50 %; the silhouettes and the bark judge those.
  double free_space_veto = 0.5;
  DbhMethod dbh_method = DbhMethod::kTangent;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    StemOptions, breast_height_m, search_radius_m, band_low_m, band_high_m, grid_m, min_cell_points,
    split_wide_parts, split_by_bearing, max_depth_smear_m, split_gap_m, split_parts_into_cores,
    split_range_gap_m, split_mixed_parts_into_cores, mixed_part_lone_core_max_share, min_points,
    min_slice_support_m2, weak_support_share, min_diameter_m, max_diameter_m, max_lean_deg,
    confirm_lean_deg, lean_slice_min_points, lean_slice_min_share, lean_circle_max_off_share,
    slice_half_m, free_space_veto, dbh_method)

// What a reader of the tree list should know about how a stem was measured (trees.csv `flags`).
enum class StemFlag : uint8_t {
  kOccluded,        // over a quarter of its silhouettes lay beside a nearer stem
  kOneSided,        // both silhouettes in fewer than three views: the width rests on one side
  kFewViews,        // fewer than four views measured it
  kNoSilhouette,    // no silhouette fit stands: the width is the cloud's
  kDepthSmeared,    // its points were smeared along the line of sight (far stems)
  kSilhouetteOnly,  // listed on its silhouettes where the cloud had no part
  // A nearer stem hid one side in every view that could have shown it: the DBH is the stand's
  // between the width its seen side gives and the widest it could be (Stem::dbh_seen_m,
  // dbh_hidden_max_m).
  kWidthFromStand,
};
inline constexpr int kStemFlagCount = 7;
// The flag's name in the outputs (`one_sided`, ...).
std::string_view FlagName(StemFlag flag);

// A set of StemFlag.
class StemFlags {
 public:
  void Set(StemFlag f) { bits_ |= Bit(f); }
  void Clear(StemFlag f) { bits_ &= static_cast<uint8_t>(~Bit(f)); }
  bool Has(StemFlag f) const { return (bits_ & Bit(f)) != 0; }
  bool empty() const { return bits_ == 0; }
  // The names of the flags set, in the enum's order.
  std::vector<std::string_view> Names() const;
  bool operator==(const StemFlags&) const = default;

 private:
  static uint8_t Bit(StemFlag f) { return static_cast<uint8_t>(1u << static_cast<int>(f)); }
  uint8_t bits_ = 0;
};

// What the silhouettes and the bark said of a stem's fit, for checking it tree by tree
// (stems_detail.csv); zero where no silhouette fit was made.
struct FitEvidence {
  int tried_views = 0;        // keyframes that should see the stem
  int two_sided_views = 0;    // of them, those that showed both of its silhouettes
  double rms_px = 0.0;        // the silhouette rays' scatter about the circle, pixels at the stem
  int bark_pairs = 0;         // keyframe pairs whose bark was compared through the circle
  double bark_ncc = 0.0;      // their mean correlation where the bark lines up best
  double bark_shift_m = 0.0;  // how far that moved the circle along the line of sight
  // The share of its silhouettes whose bands stray from a straight line as leaves' edges do
  // (JaggedSilhouetteShare).
  double jagged_share = 0.0;
  int rarer_side_views = 0;  // views that gave the silhouette of the side seen less often
  // Views that gave each side's silhouette (0 left, 1 right) clear of every nearer stem's
  // outline (SideViewsClearOfNearerStems).
  std::array<int, 2> clear_side_views = {0, 0};
  // Its sides, seen one at a time past a nearer stem, measure it (SidesSeenApart, a fit held on
  // its face, or sides shown where its cloud's circle predicts them).
  bool sides_apart = false;
};

struct Stem {
  Eigen::Vector2d centre_xy = Eigen::Vector2d::Zero();  // plot frame, at breast height
  double ground_z_m = 0.0;  // the ground on its uphill side (GroundGrid::UphillHeight)
  // The floor surface under it (GroundGrid::FloorHeight), which detection measures heights from:
  // its section is fitted breast_height_m above this, centimetres from the reported height,
  // where every threshold of the fits was set.
  double floor_z_m = 0.0;
  double dbh_m = 0.0, dbh_sd_m = 0.0;
  double confidence = 1.0;  // the chance that it is a stem (DetectionConfidence)
  double dbh_slice_m = 0.0, dbh_circle_m = 0.0;        // every estimator, whichever is reported
  double dbh_tangent_m = 0.0, dbh_tangent_sd_m = 0.0;  // 0 when the tangent fit failed
  int n_points = 0, n_views = 0;
  double arc_deg = 0.0;  // spread of the viewing directions
  double lean_deg = 0.0;
  double pass_through = 0.0;  // free-space ratio
  double fit_shift_m = 0.0;   // how far the silhouette fit moved the centre from the cloud's
  // The median distance from the plot centre of its breast-height slice's points: the face the
  // cameras saw (0 where unknown). Stereo's depth, coarse at a point, is fine in the median.
  double face_range_m = 0.0;
  // That slice's points (plot frame): where the stem's surface is, to check a silhouette fit's
  // outline against (BarkPastOutlineShare). Empty where no part of a cloud gave the stem.
  std::vector<Eigen::Vector2d> slice_xy;
  // Where a nearer stem hides one side in every view that could show it (StemFlag::
  // kWidthFromStand): the DBH its seen side and its cloud give (a lower bound), and the widest it
  // could be with that side still hidden (WidestRadiusWithSideHidden); 0 elsewhere.
  double dbh_seen_m = 0.0, dbh_hidden_max_m = 0.0;
  int hidden_side = -1;  // which (0 image left / 1 right, from the plot centre); -1: none
  FitEvidence evidence;
  // The points were smeared along the line of sight (far stems): centre and width come from
  // their spread across it, and neither is a reliable check on the silhouettes.
  bool depth_smeared = false;
  // Too little breast-height surface for its distance (a stem mostly behind shrubs, or clutter):
  // a stem only if two-sided silhouettes confirm it. Also set for a part leaning further than
  // confirm_lean_deg.
  bool weak_support = false;
  // A denser core of a part no stem as a whole (StemOptions::split_mixed_parts_into_cores):
  // where it comes to nothing, the larger cloud's stems there are tried on their own.
  bool mixed_part_core = false;
  // Where the silhouettes' votes alone gave it (VoteStemCentres): how many voted for it; 0 for
  // the clouds' parts.
  int silhouette_votes = 0;
  StemFlags flags;
  // The stems its denser cores make, when it splits into two or more on them (one alone when
  // the others are no stems).
  std::vector<Stem> alternatives;
  // The same stem as a larger cloud gave it (AttachLargerCloudParts), tried when this part comes
  // to nothing: its points may show the stem whole where this part is a sliver of it.
  std::vector<Stem> larger_cloud_part;
};

struct StemsResult {
  std::vector<Stem> stems;
  // The parts the free-space veto rejected, measured as far as the veto (pass_through set).
  std::vector<Stem> vetoed;
  int components = 0, rejected_size = 0, rejected_vertical = 0, vetoed_free_space = 0;
  int larger_cloud_parts = 0;  // AttachLargerCloudParts
  int larger_cloud_only = 0;   // stems of the larger cloud alone, tried on their silhouettes
  int silhouette_votes = 0;    // places the silhouettes alone gave (VoteStemCentres), tried last
  int mixed_part_cores = 0;    // cores of parts no stem as a whole (split_mixed_parts_into_cores)
  nlohmann::json Summary() const;
};

// Each stem of `more` (found in a larger cloud) that overlaps a stem of `found` (their circles
// within gap_m of each other) and differs from it (centres 5 cm or widths 20 % apart) becomes
// the nearest such stem's Stem::larger_cloud_part, unless it already has one nearer. Returns
// how many were attached.
int AttachLargerCloudParts(std::vector<Stem> more, double gap_m, std::vector<Stem>* found);

// Orders stems nearest the plot centre first (the detector's order, and the list's).
inline bool NearerTheCentre(const Stem& a, const Stem& b) {
  return a.centre_xy.squaredNorm() < b.centre_xy.squaredNorm();
}

// The stems of `more` whose circles come within gap_m of no stem of `found`, nearest the plot
// centre first, without their cores.
std::vector<Stem> StemsAwayFrom(std::span<const Stem> more, double gap_m,
                                std::span<const Stem> found);

// Stems from the fused cloud: occupancy of the band above the ground, connected parts, a
// verticality test, a free-space veto from the points' rays, then DBH at breast height.
// depth_focal_px (DenseResult's) scales the support test; 0 skips it.
StemsResult DetectStems(const StemOptions& options, const std::vector<dense::CloudPoint>& cloud,
                        const GroundGrid& ground, double depth_focal_px = 0.0);

// The detection band: the cloud's points within search_radius_m of the axis, band_low_m to
// band_high_m above the ground there; their heights in `height_m` where given.
std::vector<const dense::CloudPoint*> BandPoints(const StemOptions& options,
                                                 const std::vector<dense::CloudPoint>& cloud,
                                                 const GroundGrid& ground,
                                                 std::vector<double>* height_m = nullptr);

// Of the band's rays (origin -> point, in 2-D) that meet the disc (c, r), the share that pass
// through it and end well beyond; the rest end on it (`hits`, where given, counts those). A real
// trunk blocks the view, so a high share vetoes a part. 1 where no ray meets the disc.
double PassThroughRatio(const std::vector<const dense::CloudPoint*>& band, const Eigen::Vector2d& c,
                        double r, int* hits = nullptr);

// Circle through 2-D points: algebraic start, then robust geometric refinement. Returns false
// with fewer than 3 points. `rms_m` is the residual spread.
bool FitCircle(const std::vector<Eigen::Vector2d>& pts, Eigen::Vector2d* centre, double* radius,
               double* rms_m);

}  // namespace stemmap::stems
