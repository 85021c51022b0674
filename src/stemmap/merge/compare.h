#pragma once

// `stemmap compare`: an earlier inventory of a plot against a new run of it: growth per tree,
// ingrowth, trees not found.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "stemmap/merge/register.h"

namespace stemmap::merge {

struct InventoryTree {
  std::string id;  // the inventory's own tree id, or its row number
  MapStem stem;
  // Easting and northing (m, a projected CRS), where the inventory has them.
  std::optional<Eigen::Vector2d> map_xy;
};

// A run's trees, and where the run was georeferenced their easting and northing (m, the run's
// projected CRS; empty otherwise).
struct RunTrees {
  std::vector<MapStem> stems;
  std::vector<std::optional<Eigen::Vector2d>> map_xy;
};

// Any CSV with x and y (m) and a DBH column: `x_m`/`x`/`X`, `y_m`/`y`/`Y`, `dbh_cm`/`dbh` (cm) or
// `dbh_m`/`DBH` (m, as FSCT writes it); an id from `tree_id`/`id`/`tree`/`TreeId` when there;
// easting and northing from `easting_m`/`easting`/`E` and `northing_m`/`northing`/`N` when there
// (empty cells: none for that tree). With map coordinates but no x, y, those stand for x, y.
// InputError naming the file and what is missing.
std::vector<InventoryTree> ReadInventoryCsv(const std::filesystem::path& path);

struct CompareOptions {
  // Earlier trees grew: their DBH may differ more than two runs' of one date.
  RegisterOptions registration = {.match_radius_m = 0.4, .dbh_share = 0.35, .dbh_slack_cm = 4.0};
  // Where both lists are georeferenced, the registration stays within these of where the two
  // georeferences put the earlier trees (GPS centres and compass bearings err by metres and
  // degrees; a plantation's grid registers almost as well one spacing off).
  double georeference_max_shift_m = 6.0;
  double georeference_max_turn_deg = 15.0;
  double min_matched_share = 0.4;  // of the smaller list, for the lists to be of one plot
  double min_dbh_cm = 7.0;         // ingrowth counts new trees at least this thick
  void Check() const;
};

enum class CompareStatus { kMeasured, kIngrowth, kNotFound };

struct ComparedTree {
  CompareStatus status = CompareStatus::kMeasured;
  std::string earlier_id;                          // empty for ingrowth
  int new_id = 0;                                  // the run's tree_id; 0 for a tree not found
  Eigen::Vector2d xy_m = Eigen::Vector2d::Zero();  // the run's plot frame
  double earlier_dbh_cm = 0.0, dbh_cm = 0.0;
  double match_distance_m = 0.0;  // after registration
};

struct CompareResult {
  Registration registration;  // the earlier inventory onto the run's plot frame
  // Both georeferenced: the registration was held near the georeferences' transform, and how far
  // the stems put the earlier trees from where the georeferences did.
  bool georeferenced = false;
  double georeference_shift_m = 0.0;  // at the earlier trees' centroid
  double georeference_turn_deg = 0.0;
  std::vector<ComparedTree> trees;
  int measured = 0, ingrowth = 0, not_found = 0;
  double mean_growth_cm = 0.0;
};

// Earlier trees that match no run tree are "not found" only within the run's farthest stem from
// its centre. When both have map coordinates (two trees at least in each), the earlier trees are
// registered in map coordinates near where the georeferences put them.
CompareResult CompareInventories(const CompareOptions& options,
                                 const std::vector<InventoryTree>& earlier, const RunTrees& run);

// RUN_DIR/trees.csv: x_m, y_m, dbh_cm and, where the run was georeferenced, easting_m and
// northing_m.
RunTrees ReadRunTrees(const std::filesystem::path& run_dir);

// Reads EARLIER.csv and RUN_DIR/trees.csv, writes OUT/compare.csv and OUT/compare.json.
CompareResult RunCompare(const CompareOptions& options, const std::filesystem::path& earlier_csv,
                         const std::filesystem::path& run_dir,
                         const std::filesystem::path& out_dir);

}  // namespace stemmap::merge
