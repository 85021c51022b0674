#pragma once

// The tree list as rows: what trees.csv, the GeoPackage and the GeoJSON hold, computed once so
// that every file says the same of each tree.
#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "stemmap/core/enum_names.h"
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
  // For the other tools' tables: the ground at the stem (plot frame), the stem's cloud points,
  // the spread of the views that measured it, and whether a nearer stem hid part of it.
  double ground_z_m = 0.0;
  int n_points = 0;
  double arc_deg = 0.0;
  bool occluded = false;
  // The local offsets FORTLS-style tools expect: east and north of the centre with a first
  // bearing, else the plot frame's x and y.
  Eigen::Vector2d local_xy_m = Eigen::Vector2d::Zero();
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

// The tree list in other tools' formats, so their scripts take stemmap's output.
enum class TreeTableFormat {
  // FORTLS's tree.tls.csv (R write.csv): id, file, tree, x, y (m, from the plot centre: east and
  // north with a first bearing, else the plot frame), phi, phi.left, phi.right (rad, counter-
  // clockwise from x), h.dist (m), dbh (cm), h, v (NA), n.pts, n.pts.red (the stem's cloud
  // points), n.pts.est, n.pts.red.est (NA), partial.occlusion (0 or 1).
  kFortls,
  // FSCT's tree_data.csv: TreeId, x_tree_base, y_tree_base, z_tree_base (m: the projected CRS with
  // a plot centre, else the plot frame), DBH (m), CCI_at_BH (the share of the circumference the
  // views saw: half a turn plus their spread), and FSCT's height, volume and crown columns empty.
  kFsct,
};
inline constexpr EnumNames<TreeTableFormat, 2> kTreeTableFormatNames = {
    {{TreeTableFormat::kFortls, "fortls"}, {TreeTableFormat::kFsct, "fsct"}}};
STEMMAP_ENUM_JSON(TreeTableFormat, kTreeTableFormatNames, "tree table format")
// The file name the tool reads: tree.tls.csv, tree_data.csv.
std::string_view TreeTableFileName(TreeTableFormat format);
// Writes `rows` atomically to `path` in `format`; `plot_id` and `video_name` fill FORTLS's id and
// file columns.
void WriteTreeTable(TreeTableFormat format, const std::filesystem::path& path,
                    const std::vector<TreeRow>& rows, const std::string& plot_id,
                    const std::string& video_name);

}  // namespace stemmap::gis
