#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "stemmap/dense/dense.h"
#include "stemmap/dense/trunk_mask.h"
#include "stemmap/gis/georef.h"
#include "stemmap/gis/tree_table.h"
#include "stemmap/stems/measure.h"
#include "stemmap/stems/plot_figures.h"
#include "stemmap/stems/stems.h"
#include "stemmap/track/track.h"

namespace stemmap::pipeline {

struct ProcessOptions {
  track::TrackOptions track;
  dense::DenseOptions dense;
  dense::DnnMaskOptions mask;       // optional learned trunk mask (mask.model empty: none)
  stems::MeasureOptions measure;    // every stem and DBH decision
  double plot_radius_m = 10.0;      // plot figures count stems within this radius
  gis::GeoreferenceOptions georef;  // where the plot lies: centre, first bearing, CRS
  std::vector<gis::TreeTableFormat> exports;  // other tools' tree tables to write beside trees.csv
  // A finished track (`stemmap track` or `process` output folder) whose keyframe poses and
  // camera are used instead of tracking again; empty: track the video.
  std::filesystem::path from_track;
  // map.svg and report.html with a picture of each stem at breast height.
  bool write_report = true;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(ProcessOptions, track, dense, mask, measure,
                                                plot_radius_m, georef, exports, from_track,
                                                write_report)

// summary.json's "plot" object: the figures, and `warnings` when the list says less than a plot
// holds (no stem at all: not a stand at breast height, or one the method could not see).
nlohmann::json PlotSummaryJson(const stems::PlotFigures& figures,
                               const stems::Visibility& visibility, int listed_stems,
                               double plot_radius_m, double min_dbh_cm);

struct ProcessResult {
  std::vector<stems::Stem> stems;
  stems::PlotFigures figures;
  nlohmann::json summary;
  std::string Table() const;  // plain-text tree list for the terminal
};

// `stemmap process`: track (or reuse a track), dense depth, stems and DBH. Writes OUT/trees.csv,
// OUT/summary.json, OUT/process_options.json and the stages' own files (trajectory.tum, cloud.ply,
// ...).
ProcessResult RunProcess(const ProcessOptions& options, const std::filesystem::path& video,
                         const std::filesystem::path& out_dir);

// `stemmap stems`: detection and DBH again on a finished `process` run's folder (`from_dir`: its
// track, cloud.ply, cloud_coarse.ply and dense_summary.json), with the keyframes decoded from
// `video`, under `options.measure` (the track and depth options are not used). Writes what
// process writes but the depth, with the track and cloud beside it, so it can be gone on from.
ProcessResult RunStems(const ProcessOptions& options, const std::filesystem::path& video,
                       const std::filesystem::path& from_dir, const std::filesystem::path& out_dir);

// The tree list's files (trees.csv, stems_detail.csv, trees.gpkg, trees.geojson with a plot
// centre, cloud.las, the report) and the summary's "plot" and "georeference", from
// `result->stems`; sets `result->figures`.
struct TreeOutputsInput {
  const track::TrackResult* track = nullptr;
  const std::vector<cv::Mat>* images = nullptr;           // keyframe images, for the report
  const std::vector<dense::CloudPoint>* cloud = nullptr;  // for cloud.las
  const gis::Georeference* georef = nullptr;
  std::filesystem::path video;
};
void WriteTreeOutputs(const ProcessOptions& options, const TreeOutputsInput& input,
                      const std::filesystem::path& out_dir, ProcessResult* result);

// stand_table.csv: stems/ha and basal area/ha by DBH class, and a last row `all`.
void WriteStandTableCsv(const std::filesystem::path& path, const stems::PlotFigures& figures);

// Every estimator's DBH per stem (stems_detail.csv), to compare them tree by tree.
void WriteStemDetails(const std::filesystem::path& path, const std::vector<stems::Stem>& stems);

}  // namespace stemmap::pipeline
