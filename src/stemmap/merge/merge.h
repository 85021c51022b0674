#pragma once

// `stemmap merge`: several runs of one plot (other start directions, tripods up to ~2 m apart)
// registered onto the first run's plot frame by their stem maps, and one tree list of them all.
#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stemmap/merge/register.h"

namespace stemmap::merge {

struct MergeOptions {
  RegisterOptions registration;
  // A run belongs with the first when its registration matches at least this share of the
  // smaller map's stems, with residuals under max_rms_m (m).
  double min_matched_share = 0.5;
  double max_rms_m = 0.12;
  void Check() const;
};
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RegisterOptions, match_radius_m, dbh_share,
                                                dbh_slack_cm, min_spacing_m, spacing_tolerance_m,
                                                min_matches, robust_scale_m)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(MergeOptions, registration, min_matched_share,
                                                max_rms_m)

// One tree of the merged list, in the first run's plot frame.
struct MergedTree {
  Eigen::Vector2d xy_m = Eigen::Vector2d::Zero();  // mean over the runs that found it
  double dbh_cm = 0.0;                             // mean
  double dbh_sd_cm = 0.0, position_sd_m = 0.0;     // across those runs (0 for one run)
  std::vector<int> runs;                           // which runs found it (0-based)
};

struct MergeResult {
  std::vector<Registration> registrations;  // per run, onto the first (the first: identity)
  std::vector<MergedTree> trees;            // nearest the first run's centre first
  // Median over trees found by two runs or more of their DBH SD and position SD.
  double median_dbh_sd_cm = 0.0, median_position_sd_m = 0.0;
  nlohmann::json Summary() const;
};

// The stem maps of `maps` (one per run, the first the reference) registered and merged. Throws
// InputError naming the run when one does not belong with the first.
MergeResult MergeMaps(const MergeOptions& options, const std::vector<std::vector<MapStem>>& maps,
                      const std::vector<std::string>& run_names);

// The stems of a run folder's trees.csv (x_m, y_m, dbh_cm); InputError when it has none to read.
std::vector<MapStem> ReadRunStems(const std::filesystem::path& run_dir);

// Reads each run's trees.csv, merges, and writes OUT/merged_trees.csv, OUT/merge.json (each run's
// transform and how well it fits, the options) and OUT/merge_map.svg (every run's stems over the
// merged ones), atomically.
MergeResult RunMerge(const MergeOptions& options, const std::vector<std::filesystem::path>& runs,
                     const std::filesystem::path& out_dir);

}  // namespace stemmap::merge
