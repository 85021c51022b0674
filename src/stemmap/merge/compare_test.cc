#include "stemmap/merge/compare.h"

#include <gtest/gtest.h>

#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::merge {
namespace {

namespace fs = std::filesystem;

// A re-measurement five years on: every tree 1.5 cm thicker, one died (not found), one grew into
// the list, and the new capture started facing another way from a tripod set 0.6 m off.
TEST(CompareInventories, GrowthIngrowthAndTreesNotFound) {
  const std::vector<InventoryTree> earlier = {
      {"A", {{3.0, 1.0}, 30.0}, {}},  {"B", {{-2.0, 5.5}, 21.0}, {}},
      {"C", {{6.0, -4.0}, 44.0}, {}}, {"D", {{-7.0, -2.0}, 17.0}, {}},
      {"E", {{1.0, 8.0}, 37.0}, {}},  {"F", {{-4.0, -6.5}, 26.0}, {}}};
  const double a = 70 * M_PI / 180;
  std::vector<MapStem> run;
  for (const InventoryTree& t : earlier) {
    if (t.id == "D") continue;  // died
    const Eigen::Vector2d p = t.stem.xy - Eigen::Vector2d(0.6, 0.0);
    run.push_back(
        {{std::cos(-a) * p.x() - std::sin(-a) * p.y(), std::sin(-a) * p.x() + std::cos(-a) * p.y()},
         t.stem.dbh_cm + 1.5});
  }
  run.push_back({{2.0, -2.0}, 9.0});  // ingrowth
  const CompareResult r = CompareInventories({}, earlier, RunTrees{run, {}});
  EXPECT_FALSE(r.georeferenced);
  EXPECT_EQ(r.measured, 5);
  EXPECT_EQ(r.ingrowth, 1);
  EXPECT_EQ(r.not_found, 1);
  EXPECT_NEAR(r.mean_growth_cm, 1.5, 1e-9);
  EXPECT_NEAR(r.registration.yaw_deg, -70.0, 1e-6);
  for (const ComparedTree& t : r.trees) {
    if (t.status == CompareStatus::kNotFound) {
      EXPECT_EQ(t.earlier_id, "D");
    } else if (t.status == CompareStatus::kMeasured) {
      EXPECT_LT(t.match_distance_m, 1e-6);
    }
  }
}

Eigen::Vector2d Turned(double deg, const Eigen::Vector2d& p) {
  const double a = deg * M_PI / 180;
  return {std::cos(a) * p.x() - std::sin(a) * p.y(), std::sin(a) * p.x() + std::cos(a) * p.y()};
}

// A plantation on a 4-m grid, every tree of like DBH, inventoried out to 14 m: a run that lists
// the trees within 10 m fits the grid as well one spacing off as in place. Both lists are
// georeferenced (UTM-sized coordinates); the run's GPS centre errs by 2.5 m and its compass by
// 4°, over a range of directions of the GPS error: the registration is the true one, and the
// georeferences' disagreement is reported.
TEST(CompareInventories, GeoreferencesPickTheRightPlaceOnAPlantationsGrid) {
  const Eigen::Vector2d origin(512345.0, 4683210.0);
  std::vector<InventoryTree> earlier;
  for (int i = -3; i <= 3; ++i) {
    for (int j = -3; j <= 3; ++j) {
      const Eigen::Vector2d xy(4.0 * i + 0.5, 4.0 * j + 0.3);
      if (xy.norm() > 14.0) continue;
      InventoryTree t{std::to_string(earlier.size() + 1), {xy, 28.0 + ((i + j) % 3)}, {}};
      t.map_xy = origin + Turned(20.0, xy);  // the earlier plot's own x faces 20° from east
      earlier.push_back(t);
    }
  }
  for (double error_dir_deg : {0.0, 90.0, 200.0}) {
    SCOPED_TRACE(::testing::Message() << "GPS error towards " << error_dir_deg << "°");
    // The run's frame: the tripod 0.4 m off the old centre, its x facing 75° from east.
    const Eigen::Vector2d tripod(0.4, -0.2);
    RunTrees run;
    for (const InventoryTree& t : earlier) {
      const Eigen::Vector2d map = *t.map_xy;
      const Eigen::Vector2d xy = Turned(-75.0, map - origin - tripod);
      if (xy.norm() > 10.0) continue;
      run.stems.push_back({xy, t.stem.dbh_cm + 1.0});
      // Where the run's own georeference puts it: the centre 2.5 m off, the bearing 4° off.
      const Eigen::Vector2d gps = 2.5 * Turned(error_dir_deg, {1.0, 0.0});
      run.map_xy.push_back(origin + tripod + gps + Turned(75.0 + 4.0, xy));
    }
    const CompareResult r = CompareInventories({}, earlier, run);
    ASSERT_TRUE(r.georeferenced);
    EXPECT_EQ(r.measured, static_cast<int>(run.stems.size()));
    for (const ComparedTree& t : r.trees) {
      if (t.status == CompareStatus::kMeasured) {
        EXPECT_LT(t.match_distance_m, 1e-6);
      }
    }
    EXPECT_NEAR(r.registration.yaw_deg, 20.0 - 75.0, 1e-6);
    EXPECT_NEAR(std::abs(r.georeference_turn_deg), 4.0, 1e-6);
    EXPECT_GT(r.georeference_shift_m, 1.5);
    EXPECT_LT(r.georeference_shift_m, 3.5);
  }
}

// Georeferences that put the lists farther apart than the bounds: no registration is sought
// beyond them, and the error says so.
TEST(CompareInventories, ListsTheGeoreferencesPutFarApartAreRefused) {
  std::vector<InventoryTree> earlier;
  RunTrees run;
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector2d xy = 6.0 * Turned(45.0 * k, {1.0, 0.0}) + Eigen::Vector2d(0.1 * k, 0);
    earlier.push_back({std::to_string(k), {xy, 20.0 + 3 * k}, xy});
    run.stems.push_back({xy, 20.0 + 3 * k});
    run.map_xy.push_back(xy + Eigen::Vector2d(30.0, 0.0));  // 30 m east of the earlier's
  }
  try {
    CompareInventories({}, earlier, run);
    FAIL() << "registered beyond the georeferences' bounds";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("where the georeferences put it"), std::string::npos)
        << e.what();
  }
}

TEST(ReadInventoryCsv, TakesTheUsualColumnNamesAndUnits) {
  const fs::path dir = fs::path(::testing::TempDir()) / "stemmap_compare";
  fs::create_directories(dir);
  WriteFileAtomic(dir / "field.csv", "id,x,y,dbh\n7,1.5,2.0,23.4\n8,-3,4,31\n");
  const std::vector<InventoryTree> cm = ReadInventoryCsv(dir / "field.csv");
  ASSERT_EQ(cm.size(), 2u);
  EXPECT_EQ(cm[0].id, "7");
  EXPECT_EQ(cm[1].stem.dbh_cm, 31.0);
  WriteFileAtomic(dir / "fsct.csv", "TreeId,X,Y,DBH\n1,1.5,2.0,0.234\n");
  EXPECT_NEAR(ReadInventoryCsv(dir / "fsct.csv")[0].stem.dbh_cm, 23.4, 1e-9);
  WriteFileAtomic(dir / "no_dbh.csv", "id,x,y,height\n1,1,2,20\n");
  EXPECT_THROW(ReadInventoryCsv(dir / "no_dbh.csv"), InputError);
  WriteFileAtomic(dir / "bad.csv", "id,x,y,dbh\n1,1,two,20\n");
  EXPECT_THROW(ReadInventoryCsv(dir / "bad.csv"), InputError);
  // Map coordinates beside x, y; empty cells for a tree without them; alone, they stand for x, y.
  WriteFileAtomic(dir / "geo.csv",
                  "id,x,y,dbh,easting_m,northing_m\n1,1,2,20,500001,4600002\n2,3,4,25,,\n");
  const std::vector<InventoryTree> geo = ReadInventoryCsv(dir / "geo.csv");
  ASSERT_TRUE(geo[0].map_xy.has_value());
  EXPECT_EQ(geo[0].map_xy->x(), 500001.0);
  EXPECT_FALSE(geo[1].map_xy.has_value());
  WriteFileAtomic(dir / "map_only.csv", "tree,E,N,dbh_cm\n1,500001,4600002,20\n");
  EXPECT_EQ(ReadInventoryCsv(dir / "map_only.csv")[0].stem.xy.y(), 4600002.0);
}

}  // namespace
}  // namespace stemmap::merge
