#pragma once

// `stemmap batch`: a whole inventory, one plot a row of a manifest, each plot's results in
// OUT/<plot_id>/, resumable, one plot per task so an existing scheduler (GNU parallel, a Slurm job
// array) can spread the rows over machines (docs/batch.md).
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "stemmap/pipeline/process.h"

namespace stemmap::batch {

// One row of the manifest:
// plot_id,video,arm_radius_m,hfov_deg,calibration,camera_height_m,plot_centre,first_bearing_deg
// Empty cells take the defaults (`BatchOptions::process`); `plot_centre` is `LAT LON`; paths are
// relative to the manifest's folder.
struct PlotRow {
  int line = 0;  // in the manifest
  std::string plot_id;
  std::filesystem::path video;
  pipeline::ProcessOptions options;  // the defaults with the row's cells on top
};

// Throws InputError naming the manifest and line for a missing column, a cell that does not
// parse, a plot_id that is not a plain file name, or one given twice.
std::vector<PlotRow> ReadManifest(const std::filesystem::path& manifest,
                                  const pipeline::ProcessOptions& defaults);

struct BatchOptions {
  pipeline::ProcessOptions process;  // the defaults of every plot
  // Run only this row (1-based): one task of a job array or of GNU parallel. No summary.
  std::optional<int> task;
  bool summary_only = false;  // run nothing: gather the finished plots' summary
};

enum class PlotStatus { kFinished, kFailed, kPending };

struct PlotOutcome {
  std::string plot_id;
  PlotStatus status = PlotStatus::kPending;
  bool ran_now = false;  // processed by this call (not found finished)
  std::string message;   // why it failed
};

struct BatchSummary {
  std::vector<PlotOutcome> plots;
  int finished = 0, failed = 0, pending = 0, ran_now = 0;
};

// Processes the manifest's plots not yet finished (a plot is finished when OUT/<plot_id> holds a
// finished run), records a failed plot in OUT/<plot_id>.failed.json with its message and goes on,
// then (unless a task) writes OUT/batch_summary.csv (a row per plot: status, stems, stems/ha,
// basal area, QMD, message) and OUT/plots.gpkg (the trees of every finished plot with a centre,
// WGS 84, and each plot's centre).
BatchSummary RunBatch(const BatchOptions& options, const std::filesystem::path& manifest,
                      const std::filesystem::path& out_dir);

}  // namespace stemmap::batch
