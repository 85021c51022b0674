#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "stemmap/dense/dense.h"
#include "stemmap/dense/trunk_mask.h"
#include "stemmap/stems/bark_depth.h"
#include "stemmap/stems/stems.h"
#include "stemmap/stems/tangent.h"
#include "stemmap/track/track.h"

namespace stemmap::pipeline {

struct ProcessOptions {
  track::TrackOptions track;
  dense::DenseOptions dense;
  dense::DnnMaskOptions mask;  // optional learned trunk mask (mask.model empty: none)
  stems::StemOptions stems;
  stems::TangentOptions tangent;
  stems::BarkDepthOptions bark_depth;  // the tangent fit's distance from the bark
  double plot_radius_m = 10.0;         // plot figures count stems within this radius
  double min_dbh_cm = 7.0;             // and at least this thick
  // Drop cloud clusters whose silhouettes cannot be found in any view (a trunk shows two edges,
  // a leaf clump rarely does). On the simulated plots it removes only false stems (see
  // benchmarks.md); --keep-unconfirmed turns it off.
  bool require_silhouette = true;
  // Unless the fit failed only on the bark (BarkConfirmsCloud): a stem standing in front of a
  // wider one shows its silhouettes against that one's bark, and a fit to them can settle on the
  // stem behind, where the bark does not line up; the part's own circle, where it does, stays.
  bool keep_bark_confirmed_cloud = true;
  // Silhouettes on one side only cannot tell how far the stem reaches on the other: such a fit
  // wider than this many times the cloud's width keeps the cloud's (see benchmarks.md), unless
  // its rays agree to about a pixel and the cloud saw at least this radius (a stem half hidden by
  // a nearer one, not a twig that one loose side widened).
  double one_sided_max_over_cloud = 1.1;
  double one_sided_min_cloud_radius_m = 0.075;
  // A part that silhouettes do not fit is replaced by its dense cores that they fit cleanly; when
  // the part is kept on its cloud (one stem, perhaps widened by a shrub), only by cores at least
  // this share of its width (a narrower one is a piece of the stem's bark).
  double min_core_share = 0.6;
  // A smeared part whose silhouettes fit a stem under this share of its width may be stems one
  // behind another: its cores replace it when two or more of them fit cleanly on their own.
  double narrow_fit_share = 0.6;
  // Two listed stems whose bark comes closer than this at breast height are one stem fitted
  // twice (a fit that slid along its line of sight onto a nearer stem's silhouette): the one
  // whose fit moved farther from its points is dropped.
  double min_bark_gap_m = 0.02;
  // A stem found with the short-baseline points too (DenseOptions::short_baseline_max_depth_m)
  // within this of a part of the cloud is that part's second start (Stem::larger_cloud_part).
  double larger_cloud_part_gap_m = 0.1;
  // A finished track (`stemmap track` or `process` output folder) whose keyframe poses and
  // camera are used instead of tracking again; empty: track the video.
  std::filesystem::path from_track;
  // map.svg and report.html with a picture of each stem at breast height.
  bool write_report = true;
  void Check() const;
};

// Plot-level figures foresters use.
struct PlotFigures {
  int stems = 0;
  double stems_per_ha = 0.0, basal_area_m2_per_ha = 0.0, qmd_cm = 0.0;
};
PlotFigures ComputePlotFigures(const std::vector<stems::Stem>& stems, double plot_radius_m,
                               double min_dbh_cm);

// summary.json's "plot" object: the figures, and `warnings` when the list says less than a plot
// holds (no stem at all: not a stand at breast height, or one the method could not see).
nlohmann::json PlotSummaryJson(const PlotFigures& figures, int listed_stems, double plot_radius_m,
                               double min_dbh_cm);

struct ProcessResult {
  std::vector<stems::Stem> stems;
  PlotFigures figures;
  nlohmann::json summary;
  std::string Table() const;  // plain-text tree list for the terminal
};

// `stemmap process`: track (or reuse a track), dense depth, stems and DBH. Writes OUT/trees.csv,
// OUT/summary.json, OUT/process_options.json and the stages' own files (trajectory.tum, cloud.ply,
// ...).
ProcessResult RunProcess(const ProcessOptions& options, const std::filesystem::path& video,
                         const std::filesystem::path& out_dir);

// What a silhouette fit does to a stem found in the cloud.
enum class SilhouetteVerdict {
  kUse,        // plausible: the fit places the stem (and gives the DBH with the tangent method)
  kKeepCloud,  // implausible: the cloud's estimate stays, flagged no_silhouette
  kDrop,       // implausible for a part that needed confirming: not a stem
};
// `px_m` is one pixel's footprint at the stem's distance.
SilhouetteVerdict JudgeSilhouetteFit(const ProcessOptions& o, const stems::Stem& stem,
                                     const stems::TangentFit& fit, double px_m);

// Whether a part whose silhouette fit failed is a stem all the same, kept on its cloud: its
// silhouettes were found on both sides in a quarter of the views tried (a trunk's two edges; a
// shrub or sapling seldom shows them so), it was not weakly supported, and the views warped
// through its own cloud circle line up (`cloud_bark` ok and not at the end of its search).
bool BarkConfirmsCloud(const stems::Stem& part, const stems::TangentFit& fit,
                       const stems::BarkDepth& cloud_bark);

// Drops the stems whose bark comes within `min_bark_gap_m` of another's (ProcessOptions), the
// one whose fit moved farther from its points (Stem::fit_shift_m) first. Returns how many.
int DropStemsFittedTwice(double min_bark_gap_m, std::vector<stems::Stem>* stems);

// A stem as its silhouettes judged it; `clean`: both sides in a quarter of its views, on one
// circle to a couple of pixels; `whole`: both sides in at least half of them.
struct RefinedStem {
  SilhouetteVerdict verdict = SilhouetteVerdict::kDrop;
  stems::Stem stem;
  bool clean = false;
  bool whole = false;
  // Whether the silhouettes' circle agrees with the cloud's width (within a fifth of it).
  bool agrees_with_cloud = false;
};
struct PartOutcome {
  int fitted = 0;      // stems placed by their silhouettes
  int from_cores = 0;  // of which the part's dense cores (Stem::alternatives)
  int dropped = 0;     // parts that are no stem
};
// What one part of the cloud becomes, appended to `kept`: the stem its silhouettes fit, the stems
// its cores make, the stem of its cloud, or nothing. `refine` judges one stem by its silhouettes.
PartOutcome ResolvePart(const ProcessOptions& o, stems::Stem part,
                        const std::function<RefinedStem(stems::Stem)>& refine,
                        std::vector<stems::Stem>* kept);

// The stems that one part of the cloud became (`fitted`) replace that part's circle (x, y,
// radius) among the occluders that farther stems' edge searches stop at; a part that became
// nothing keeps its cloud circle.
void PlaceFittedOccluders(std::span<const stems::Stem> fitted, size_t part,
                          std::vector<Eigen::Vector3d>* occluders);

// Whether `centre` (plot frame) lies straight behind one of the `nearer` stems seen from the plot
// centre: farther than its far side and within its angular width.
bool InShadowOfNearerStem(std::span<const stems::Stem> nearer, const Eigen::Vector2d& centre);

// Whether a fit rests on silhouettes of its stem's own, not on a nearer stem's edges (`px_m`: one
// pixel's footprint at the stem).
bool StandsOnItsOwnSilhouettes(const stems::TangentOptions& o, const stems::TangentFit& fit,
                               double px_m);

// The tangent fit checked on the bark: its distance from the bark (returned), and a fit whose bark
// lines up at no distance (correlation under min_surface_ncc over enough pairs) or best at the end
// of the search (beyond it, likely) fails.
stems::BarkDepth CheckFitOnBark(const stems::BarkDepthOptions& o, const stems::TangentOptions& t,
                                const stems::TangentViews& views, double breast_z,
                                stems::TangentFit* fit);

// Runs the tangent-ray estimator on every stem. A plausible fit places the stem; with the tangent
// method it also gives the DBH. `gray_full`: the keyframes' luma at the video's resolution
// (blurred in place), or empty to use `bgr` at the working resolution.
void RefineWithTangentRays(const ProcessOptions& o, const track::TrackResult& tr,
                           std::vector<cv::Mat> gray_full, const std::vector<cv::Mat>& bgr,
                           std::vector<stems::Stem>* stems);

// Every estimator's DBH per stem (stems_detail.csv), to compare them tree by tree.
void WriteStemDetails(const std::filesystem::path& path, const std::vector<stems::Stem>& stems);

// trees.csv as in docs/output-format.md, written atomically.
void WriteTreesCsv(const std::filesystem::path& path, const std::vector<stems::Stem>& stems,
                   double breast_height_m, double plot_radius_m);

}  // namespace stemmap::pipeline
