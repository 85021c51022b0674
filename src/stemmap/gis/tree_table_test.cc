#include "stemmap/gis/tree_table.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <vector>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::gis {
namespace {

namespace fs = std::filesystem;

std::vector<std::vector<std::string>> ReadCsv(const fs::path& path) {
  std::vector<std::vector<std::string>> table;
  std::istringstream in(ReadFileToString(path));
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> fields;
    std::stringstream ss(line);
    for (std::string f; std::getline(ss, f, ',');) fields.push_back(f);
    if (!line.empty() && line.back() == ',') fields.emplace_back();
    table.push_back(fields);
  }
  return table;
}

std::vector<stems::Stem> TwoStems() {
  stems::Stem a;
  a.centre_xy = {0.0, 5.0};  // a quarter turn left of the first view
  a.dbh_m = 0.30;
  a.ground_z_m = 0.12;
  a.n_points = 840;
  a.arc_deg = 90.0;
  a.flags.Set(stems::StemFlag::kOccluded);
  stems::Stem b;
  b.centre_xy = {9.9, 0.0};  // on the edge of a 10-m plot
  b.dbh_m = 0.25;
  return {a, b};
}

TEST(TreeRows, CarryBearingsEdgeFlagsAndLocalOffsets) {
  GeoreferenceOptions o;
  o.first_bearing_deg = 100.0;
  const std::vector<TreeRow> rows = TreeRows({}, TwoStems(), Georeference(o));
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_NEAR(rows[0].bearing_deg.value(), 10.0, 1e-9);
  EXPECT_NEAR(rows[0].local_xy_m.x(), 5 * std::sin(10 * M_PI / 180), 1e-9);
  EXPECT_NEAR(rows[0].local_xy_m.y(), 5 * std::cos(10 * M_PI / 180), 1e-9);
  EXPECT_EQ(rows[0].flags, "occluded");
  EXPECT_EQ(rows[1].flags, "plot_edge");  // 0.1 m inside, within its 0.25-m DBH of the edge
  EXPECT_FALSE(rows[0].map.has_value());
  const std::vector<TreeRow> plain = TreeRows({}, TwoStems(), Georeference({}));
  EXPECT_FALSE(plain[0].bearing_deg.has_value());
  EXPECT_EQ(plain[0].local_xy_m, Eigen::Vector2d(0.0, 5.0));
}

// The formats are saved by name (`process_options.json` `exports`), and only their names read back.
TEST(TreeTables, FormatsReadBackByNameOnly) {
  const nlohmann::json j = std::vector<TreeTableFormat>{TreeTableFormat::kFsct};
  EXPECT_EQ(j.dump(), R"(["fsct"])");
  EXPECT_EQ(j.get<std::vector<TreeTableFormat>>().front(), TreeTableFormat::kFsct);
  EXPECT_THROW((void)nlohmann::json("3dfin").get<TreeTableFormat>(), InputError);
}

TEST(TreeTables, FortlsGetsItsColumnsAndUnits) {
  const fs::path dir = fs::path(::testing::TempDir()) / "stemmap_tree_tables";
  fs::create_directories(dir);
  const std::vector<TreeRow> rows = TreeRows({}, TwoStems(), Georeference({}));
  EXPECT_EQ(TreeTableFileName(TreeTableFormat::kFortls), "tree.tls.csv");
  WriteTreeTable(TreeTableFormat::kFortls, dir / "tree.tls.csv", rows, "plot7", "plot7.mp4");
  const auto t = ReadCsv(dir / "tree.tls.csv");
  ASSERT_EQ(t.size(), 3u);
  ASSERT_EQ(t[0].size(), 17u);
  EXPECT_EQ(t[0][5], "\"phi\"");
  EXPECT_EQ(t[0][9], "\"dbh\"");
  EXPECT_EQ(t[1][0], "\"plot7\"");
  EXPECT_NEAR(std::stod(t[1][5]), M_PI / 2, 1e-4);    // radians, counter-clockwise from x
  EXPECT_GT(std::stod(t[1][6]), std::stod(t[1][5]));  // the left edge is counter-clockwise
  EXPECT_NEAR(std::stod(t[1][6]) - std::stod(t[1][7]), 2 * std::asin(0.15 / 5), 1e-4);
  EXPECT_NEAR(std::stod(t[1][8]), 5.0, 1e-9);
  EXPECT_NEAR(std::stod(t[1][9]), 30.0, 1e-9);  // cm
  EXPECT_EQ(t[1][10], "NA");
  EXPECT_EQ(t[1][12], "840");
  EXPECT_EQ(t[1][16], "1");
  EXPECT_EQ(t[2][16], "0");
}

TEST(TreeTables, FsctGetsItsColumnsInMetres) {
  const fs::path dir = fs::path(::testing::TempDir()) / "stemmap_tree_tables";
  fs::create_directories(dir);
  GeoreferenceOptions o;
  o.centre_easting_m = 500000.0;
  o.centre_northing_m = 4000000.0;
  o.crs = "EPSG:32630";
  o.first_bearing_deg = 90.0;  // the first view looks east: the first stem lies north
  const std::vector<TreeRow> rows = TreeRows({}, TwoStems(), Georeference(o));
  WriteTreeTable(TreeTableFormat::kFsct, dir / "tree_data.csv", rows, "p", "p.mp4");
  const auto t = ReadCsv(dir / "tree_data.csv");
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[0][0], "TreeId");
  EXPECT_EQ(t[0][4], "DBH");
  ASSERT_EQ(t[1].size(), t[0].size());
  EXPECT_NEAR(std::stod(t[1][1]), 500000.0, 1e-3);
  EXPECT_NEAR(std::stod(t[1][2]), 4000005.0, 1e-3);
  EXPECT_NEAR(std::stod(t[1][3]), 0.12, 1e-9);
  EXPECT_NEAR(std::stod(t[1][4]), 0.30, 1e-9);  // metres
  EXPECT_NEAR(std::stod(t[1][5]), 0.75, 1e-9);  // half a turn and the views' 90°
  EXPECT_EQ(t[1][6], "");                       // no height
}

}  // namespace
}  // namespace stemmap::gis
