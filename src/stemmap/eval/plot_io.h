#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "stemmap/core/pose.h"

namespace stemmap::eval {

// A stem with where it stands (plot frame, m) and its DBH (cm).
struct StemRecord {
  int id = 0;
  double x_m = 0.0;
  double y_m = 0.0;
  double dbh_cm = 0.0;
  double dbh_sd_cm = 0.0;  // predictions only; 0 when unknown
  std::string flags;       // predictions only
  double DistanceM() const;
};

struct TruthPlot {
  std::vector<StemRecord> trees;   // plot trees (saplings excluded)
  std::vector<StampedPose> poses;  // camera poses, world_from_cam, may be empty
  double arm_radius_m = 0.0;
};

// Reads stemmap's truth.json (docs/output-format.md). Throws InputError on a malformed file.
TruthPlot ReadTruthJson(const std::filesystem::path& path);

// Reads a tree list CSV with at least x_m, y_m and dbh_cm columns (tree_id, dbh_sd_cm and flags
// are used when present).
std::vector<StemRecord> ReadTreesCsv(const std::filesystem::path& path);

}  // namespace stemmap::eval
