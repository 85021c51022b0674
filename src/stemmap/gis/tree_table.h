#pragma once

// The tree list as rows: what trees.csv, the GeoPackage and the GeoJSON hold, computed once so
// that every file says the same of each tree.
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "stemmap/gis/georef.h"
#include "stemmap/stems/stems.h"

namespace stemmap::gis {

struct TreeRow {
  int tree_id = 0;                                 // 1, 2, … as listed
  Eigen::Vector2d xy_m = Eigen::Vector2d::Zero();  // plot frame, at breast height
  double z_m = 0.0;                                // height of that point in the plot frame
  double dbh_cm = 0.0, dbh_sd_cm = 0.0;
  double distance_m = 0.0;
  double azimuth_deg = 0.0;           // counter-clockwise from the first view
  std::optional<double> bearing_deg;  // compass bearing from the centre (--first-bearing)
  std::optional<MapPoint> map;        // with a plot centre
  int n_views = 0;
  double confidence = 0.0;
  std::string flags;  // ';'-separated flag names
};

// One row per stem, in the given order. `plot_edge` is added to the flags of a borderline stem:
// its centre within one DBH of the plot radius (stems::PlotFigures counts them).
struct TreeRowOptions {
  double breast_height_m = 1.3;
  double plot_radius_m = 10.0;
};
std::vector<TreeRow> TreeRows(const TreeRowOptions& options, const std::vector<stems::Stem>& stems,
                              const Georeference& georef);

// trees.csv (docs/output-format.md), written atomically. The georeferenced columns (bearing_deg,
// easting_m, northing_m, lat, lon) are always there, empty where nothing ties the plot to the map.
void WriteTreesCsv(const std::filesystem::path& path, const std::vector<TreeRow>& rows);

}  // namespace stemmap::gis
