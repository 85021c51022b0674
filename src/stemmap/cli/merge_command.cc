#include <fmt/format.h>

#include <filesystem>
#include <memory>

#include "stemmap/cli/commands.h"
#include "stemmap/merge/compare.h"
#include "stemmap/merge/merge.h"

namespace stemmap::cli {

void AddMergeCommand(CLI::App& app) {
  auto opt = std::make_shared<merge::MergeOptions>();
  auto runs = std::make_shared<std::vector<std::filesystem::path>>();
  auto out = std::make_shared<std::filesystem::path>();
  CLI::App* sub = app.add_subcommand(
      "merge",
      "One tree list from several runs of one plot (other start directions, tripods up to ~2 m "
      "apart), registered onto the first run by their stem maps");
  sub->add_option("runs", *runs, "Output folders of `stemmap process` runs of one plot")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--out", *out, "Output folder")->required();
  sub->add_option("--match-radius", opt->registration.match_radius_m,
                  "Stems of two runs this close after registration are one tree (m)")
      ->capture_default_str();
  sub->add_option("--min-share", opt->min_matched_share,
                  "Share of the smaller run's stems that must match for runs to belong together")
      ->capture_default_str();
  sub->callback([sub, opt, runs, out] {
    ApplyLogLevel(*sub);
    const merge::MergeResult r = merge::RunMerge(*opt, *runs, *out);
    fmt::print("run 1: the frame of the merged list\n");
    for (size_t k = 1; k < r.registrations.size(); ++k) {
      const merge::Registration& g = r.registrations[k];
      fmt::print(
          "run {}: turned {:.2f}°, moved ({:.3f}, {:.3f}) m, {} stems matched, residual "
          "{:.3f} m\n",
          k + 1, g.yaw_deg, g.translation_m.x(), g.translation_m.y(), g.matches.size(), g.rms_m);
    }
    fmt::print(
        "{} trees; across runs median DBH SD {:.2f} cm, median position SD {:.3f} m\nwrote {}\n",
        r.trees.size(), r.median_dbh_sd_cm, r.median_position_sd_m, out->string());
  });
}

void AddCompareCommand(CLI::App& app) {
  auto opt = std::make_shared<merge::CompareOptions>();
  auto earlier = std::make_shared<std::filesystem::path>();
  auto run = std::make_shared<std::filesystem::path>();
  auto out = std::make_shared<std::filesystem::path>();
  CLI::App* sub = app.add_subcommand(
      "compare",
      "An earlier inventory of the plot (any CSV with x, y and DBH columns) against a new run: "
      "growth per tree, ingrowth, trees not found (compare.csv, compare.json)");
  sub->add_option("earlier", *earlier, "The earlier inventory (CSV)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("run", *run, "Output folder of a `stemmap process` run of the plot")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--out", *out, "Output folder")->required();
  sub->add_option("--min-dbh", opt->min_dbh_cm, "Smallest DBH counted as ingrowth (cm)")
      ->capture_default_str();
  sub->callback([sub, opt, earlier, run, out] {
    ApplyLogLevel(*sub);
    const merge::CompareResult r = merge::RunCompare(*opt, *earlier, *run, *out);
    fmt::print(
        "{} trees measured again (mean growth {:.1f} cm), {} ingrowth, {} not found; the earlier "
        "list turned {:.1f}° and moved ({:.2f}, {:.2f}) m onto the run\nwrote {}\n",
        r.measured, r.mean_growth_cm, r.ingrowth, r.not_found, r.registration.yaw_deg,
        r.registration.translation_m.x(), r.registration.translation_m.y(), out->string());
  });
}

}  // namespace stemmap::cli
