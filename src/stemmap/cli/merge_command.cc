#include <fmt/format.h>

#include <filesystem>
#include <memory>

#include "stemmap/cli/commands.h"
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

}  // namespace stemmap::cli
