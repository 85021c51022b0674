#include "stemmap/merge/merge.h"

#include <gtest/gtest.h>

#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::merge {
namespace {

namespace fs = std::filesystem;

std::vector<MapStem> Turned(const std::vector<MapStem>& m, double yaw_deg, Eigen::Vector2d shift) {
  const double a = yaw_deg * M_PI / 180, c = std::cos(a), s = std::sin(a);
  std::vector<MapStem> out;
  for (const MapStem& t : m) {
    out.push_back(
        {Eigen::Vector2d(c * t.xy.x() - s * t.xy.y(), s * t.xy.x() + c * t.xy.y()) + shift,
         t.dbh_cm});
  }
  return out;
}

const std::vector<MapStem> kPlot = {{{3.0, 1.0}, 31.0},  {{-2.0, 5.5}, 22.0},
                                    {{6.0, -4.0}, 45.0}, {{-7.0, -2.0}, 18.0},
                                    {{1.0, 8.0}, 38.0},  {{-4.0, -6.5}, 27.0}};

TEST(MergeMaps, OneTreeListWithTheSpreadOfEachTreeAcrossRuns) {
  std::vector<MapStem> second = Turned(kPlot, 40.0, {0.7, -0.3});
  second[0].dbh_cm += 1.0;           // the second run read the first tree 1 cm thicker
  second.erase(second.begin() + 5);  // and missed the last
  const std::vector<MapStem> third = Turned(kPlot, -120.0, {-1.0, 0.4});
  const MergeResult r = MergeMaps({}, {kPlot, second, third}, {"a", "b", "c"});
  ASSERT_EQ(r.registrations.size(), 3u);
  EXPECT_NEAR(r.registrations[1].yaw_deg, -40.0, 1e-6);
  ASSERT_EQ(r.trees.size(), kPlot.size());
  for (const MergedTree& t : r.trees) {
    EXPECT_EQ(t.runs.size(), t.xy_m.isApprox(Eigen::Vector2d(-4.0, -6.5), 1e-6) ? 2u : 3u);
    EXPECT_LT(t.position_sd_m, 1e-6);
  }
  const MergedTree& first = r.trees[0];  // (3, 1) is nearest the centre
  EXPECT_NEAR(first.dbh_cm, 31.0 + 1.0 / 3, 1e-9);
  EXPECT_NEAR(first.dbh_sd_cm, std::sqrt((2 * std::pow(1.0 / 3, 2) + std::pow(2.0 / 3, 2)) / 2),
              1e-9);
  EXPECT_EQ(r.median_dbh_sd_cm, 0.0);
}

TEST(MergeMaps, ARunOfAnotherPlotIsRefusedByName) {
  const std::vector<MapStem> other = {
      {{2.0, -3.0}, 12.0}, {{-5.0, 1.0}, 40.0}, {{4.0, 6.0}, 25.0}, {{-1.0, -8.0}, 33.0}};
  try {
    MergeMaps({}, {kPlot, other}, {"plot7/run", "plot9/run"});
    ADD_FAILURE() << "merged two plots";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("plot9/run does not belong with plot7/run"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(MergeMaps({}, {kPlot}, {"a"}), InputError);
}

TEST(RunMerge, ReadsRunFoldersAndWritesTheMergedList) {
  const fs::path dir = fs::path(::testing::TempDir()) / "stemmap_merge";
  fs::remove_all(dir);
  auto write_run = [&](const std::string& name, const std::vector<MapStem>& m) {
    std::string csv = "tree_id,x_m,y_m,z_m,dbh_cm,flags\n";
    int id = 0;
    for (const MapStem& t : m) {
      csv += std::to_string(++id) + "," + std::to_string(t.xy.x()) + "," +
             std::to_string(t.xy.y()) + ",1.3," + std::to_string(t.dbh_cm) + ",\n";
    }
    WriteFileAtomic(dir / name / "trees.csv", csv);
    return dir / name;
  };
  const fs::path a = write_run("a", kPlot), b = write_run("b", Turned(kPlot, 200.0, {1.5, 0.5}));
  const MergeResult r = RunMerge({}, {a, b}, dir / "merged");
  EXPECT_EQ(r.trees.size(), kPlot.size());
  for (const char* f : {"merged_trees.csv", "merge.json", "merge_map.svg"}) {
    EXPECT_TRUE(fs::exists(dir / "merged" / f)) << f;
  }
  const nlohmann::json j = ReadJsonFile(dir / "merged" / "merge.json");
  EXPECT_NEAR(j["runs"][1]["yaw_deg"].get<double>(), 160.0, 1e-4);
  EXPECT_EQ(j["trees_in_every_run"].get<int>(), 6);
  WriteFileAtomic(dir / "bad" / "trees.csv", "tree_id,x_m,y_m,dbh_cm\n1,2,x,30\n");
  EXPECT_THROW(ReadRunStems(dir / "bad"), InputError);
  EXPECT_THROW(ReadRunStems(dir / "none"), InputError);
}

}  // namespace
}  // namespace stemmap::merge
