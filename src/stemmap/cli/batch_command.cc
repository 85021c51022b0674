#include <fmt/format.h>

#include <filesystem>
#include <memory>

#include "stemmap/batch/batch.h"
#include "stemmap/cli/commands.h"

namespace stemmap::cli {

void AddBatchCommand(CLI::App& app) {
  auto opt = std::make_shared<batch::BatchOptions>();
  auto manifest = std::make_shared<std::filesystem::path>();
  auto out = std::make_shared<std::filesystem::path>();
  auto task = std::make_shared<int>(0);
  CLI::App* sub = app.add_subcommand(
      "batch",
      "Many plots, one row each of a manifest (plot_id,video,arm_radius_m,hfov_deg,calibration,"
      "camera_height_m,vertical,plot_centre,first_bearing_deg): each plot's run in OUT/<plot_id>/, "
      "finished "
      "plots not redone, failed ones recorded; batch_summary.csv and plots.gpkg (docs/batch.md)");
  sub->add_option("manifest", *manifest, "The manifest (CSV)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--out", *out, "Output folder of the whole batch")->required();
  CLI::Option* task_flag =
      sub->add_option("--task", *task,
                      "Run only this row (1-based), as one task of GNU parallel or a Slurm job "
                      "array; no summary (gather it with --summary when all are done)");
  sub->add_flag("--summary", opt->summary_only,
                "Run nothing: write the summary of the plots finished so far")
      ->excludes(task_flag);
  sub->add_option("--plot-radius", opt->process.plot_radius_m, "Plot radius of every plot (m)")
      ->capture_default_str();
  sub->add_option("--min-dbh", opt->process.measure.min_dbh_cm, "Smallest DBH counted (cm)")
      ->capture_default_str();
  sub->callback([sub, opt, manifest, out, task, task_flag] {
    ApplyLogLevel(*sub);
    if (task_flag->count() > 0) opt->task = *task;
    const batch::BatchSummary s = batch::RunBatch(*opt, *manifest, *out);
    fmt::print("{} plots: {} finished ({} now), {} failed, {} pending\nwrote {}\n", s.plots.size(),
               s.finished, s.ran_now, s.failed, s.pending, out->string());
    if (s.failed > 0 && opt->task) throw ProcessingError("this plot failed");
  });
}

}  // namespace stemmap::cli
