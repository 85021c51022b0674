#include "stemmap/sim/scene.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::sim {
namespace {

TEST(Scene, SameSeedSameSceneAndKindsDiffer) {
  SceneOptions o;
  o.seed = 4;
  const Scene a = GenerateScene(o), b = GenerateScene(o);
  ASSERT_EQ(a.trees.size(), b.trees.size());
  for (size_t i = 0; i < a.trees.size(); ++i) {
    EXPECT_EQ(a.trees[i].stem.params().base_world, b.trees[i].stem.params().base_world);
  }
  o.kind = StandKind::kNatural;
  const Scene n = GenerateScene(o);
  EXPECT_FALSE(n.shrubs.empty());
  bool has_sapling = false;
  for (const auto& t : n.trees) has_sapling |= t.sapling;
  EXPECT_TRUE(has_sapling);
}

TEST(Scene, StandsAreRealistic) {
  for (StandKind kind : {StandKind::kManaged, StandKind::kNatural}) {
    for (uint64_t seed = 1; seed <= 3; ++seed) {
      SceneOptions o;
      o.kind = kind;
      o.seed = seed;
      const Scene s = GenerateScene(o);
      int in_plot = 0;
      double farthest = 0;
      for (const auto& t : s.trees) {
        if (t.sapling) {
          EXPECT_LT(t.stem.params().radius_bh_m, 0.035);
          continue;
        }
        const Eigen::Vector3d bh = t.stem.AxisPoint(t.stem.params().s_bh_m);
        const double d = bh.head<2>().norm();
        EXPECT_GT(d, o.keep_clear_m - 0.2);
        EXPECT_GE(t.stem.params().radius_bh_m, 0.05);
        EXPECT_LE(t.stem.params().radius_bh_m, 0.30);
        // Breast height sits 1.37 m above the ground on the uphill side (or above the base).
        EXPECT_NEAR(bh.z() - s.ground.Height(bh.x(), bh.y()), kBreastHeightM, 0.15);
        in_plot += d <= 10.0;
        farthest = std::max(farthest, d);
      }
      EXPECT_GE(in_plot, 5) << ToString(kind) << " seed " << seed;
      EXPECT_LE(in_plot, 60);
      EXPECT_GE(farthest, 25.0);
      EXPECT_LE(s.ground.slope_deg(), kind == StandKind::kNatural ? 8.0 : 3.0);
    }
  }
}

TEST(Scene, LayoutCsvSelectsOnePlot) {
  const auto path = std::filesystem::temp_directory_path() / "stemmap_layout_test.csv";
  WriteFileAtomic(path, "\"id\",\"x\",\"y\",\"dbh\"\n1,3.0,0.5,30\n1,-4,2,25\n2,1,1,40\n");
  const auto first = ReadLayoutCsv(path);
  ASSERT_EQ(first.size(), 2u);
  EXPECT_DOUBLE_EQ(first[1].x_m, -4.0);
  EXPECT_EQ(ReadLayoutCsv(path, "2").size(), 1u);
  EXPECT_THROW(ReadLayoutCsv(path, "7"), InputError);
  SceneOptions o;
  o.layout = first;
  const Scene s = GenerateScene(o);
  const auto& p = s.trees.front().stem;
  EXPECT_NEAR(p.AxisPoint(p.params().s_bh_m).x(), 3.0, 1e-6);
  WriteFileAtomic(path, "a,b\n1,2\n");
  EXPECT_THROW(ReadLayoutCsv(path), InputError);
}

}  // namespace
}  // namespace stemmap::sim
