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
      {"A", {{3.0, 1.0}, 30.0}},   {"B", {{-2.0, 5.5}, 21.0}}, {"C", {{6.0, -4.0}, 44.0}},
      {"D", {{-7.0, -2.0}, 17.0}}, {"E", {{1.0, 8.0}, 37.0}},  {"F", {{-4.0, -6.5}, 26.0}}};
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
  const CompareResult r = CompareInventories({}, earlier, run);
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
}

}  // namespace
}  // namespace stemmap::merge
