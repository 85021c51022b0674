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
  // A stem of the larger cloud (vetoed by free space or not) with no part of the cloud within
  // that gap is tried last, and listed only on sharp silhouettes: both sides in at least three
  // views, on one circle to this many pixels rms (a nearer stem hides it for most of the turn,
  // and its few two-sided views are all there is; clutter's edges are not tangent to one circle
  // to a fraction of a pixel). 0: not tried.
  double larger_cloud_only_max_rms_px = 0.5;
  // A fit over this many times the cloud's radius found silhouettes beyond anything the cloud
  // saw (a wide start that closed on a sapling and the stem behind it, or on two neighbours):
  // only the bark between them can say they enclose one stem, so it stands only where the bark
  // lines up to at least this correlation over enough pairs (BarkDepthOptions::min_pairs).
  double wide_fit_scale = 2.0;
  double wide_fit_min_bark_ncc = 0.5;
  // A finished track (`stemmap track` or `process` output folder) whose keyframe poses and
  // camera are used instead of tracking again; empty: track the video.
  std::filesystem::path from_track;
  // map.svg and report.html with a picture of each stem at breast height.
  bool write_report = true;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    ProcessOptions, track, dense, mask, stems, tangent, bark_depth, plot_radius_m, min_dbh_cm,
    require_silhouette, keep_bark_confirmed_cloud, one_sided_max_over_cloud,
    one_sided_min_cloud_radius_m, min_core_share, narrow_fit_share, min_bark_gap_m,
    larger_cloud_part_gap_m, larger_cloud_only_max_rms_px, wide_fit_scale, wide_fit_min_bark_ncc,
    from_track, write_report)

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

// Every estimator's DBH per stem (stems_detail.csv), to compare them tree by tree.
void WriteStemDetails(const std::filesystem::path& path, const std::vector<stems::Stem>& stems);

// trees.csv as in docs/output-format.md, written atomically.
void WriteTreesCsv(const std::filesystem::path& path, const std::vector<stems::Stem>& stems,
                   double breast_height_m, double plot_radius_m);

}  // namespace stemmap::pipeline
