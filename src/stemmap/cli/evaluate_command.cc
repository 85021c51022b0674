#include <fmt/format.h>

#include <memory>

#include "stemmap/cli/commands.h"
#include "stemmap/eval/evaluate.h"

namespace stemmap::cli {

void AddEvaluateCommand(CLI::App& app) {
  auto opt = std::make_shared<eval::EvaluateOptions>();
  auto files = std::make_shared<eval::EvaluateFiles>();
  CLI::App* sub = app.add_subcommand(
      "evaluate", "Score a tree list (and trajectory) against a simulated plot's truth");
  sub->add_option("--truth", files->truth_json, "truth.json from stemmap simulate")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--pred", files->trees_csv, "trees.csv to score")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--trajectory", files->trajectory_tum, "Estimated trajectory (TUM)")
      ->check(CLI::ExistingFile);
  sub->add_option("--plot-radius", opt->plot_radius_m, "Scored plot radius (m)")
      ->capture_default_str();
  sub->add_option("--min-dbh", opt->min_dbh_cm, "Smallest scored DBH (cm)")->capture_default_str();
  sub->add_option("--match-radius", opt->match_radius_m, "Largest match distance (m)")
      ->capture_default_str();
  sub->add_option("--out", files->out_dir, "Folder for evaluation.json and evaluation.md");
  sub->callback([sub, opt, files] {
    ApplyLogLevel(*sub);
    const eval::Evaluation e = eval::RunEvaluate(*opt, *files);
    fmt::print("{}", e.ToMarkdown());
  });
}

}  // namespace stemmap::cli
