// End to end: simulate a short plot, decode it, and score the truth against itself.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "stemmap/core/io.h"
#include "stemmap/eval/evaluate.h"
#include "stemmap/sim/simulate.h"
#include "stemmap/video/video_reader.h"

namespace stemmap {
namespace {

namespace fs = std::filesystem;

TEST(EndToEnd, SimulateDecodeEvaluate) {
  const fs::path dir = fs::temp_directory_path() / ("stemmap_e2e_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  sim::SimulateOptions o;
  o.seed = 3;
  o.kind = sim::StandKind::kNatural;
  o.out_dir = dir;
  o.width = 320;
  o.height = 180;
  o.fps = 10;
  o.seconds = 3;
  o.stills = 1;
  const sim::SimulateSummary s = sim::RunSimulate(o);
  EXPECT_EQ(s.frames, 30);
  ASSERT_TRUE(fs::exists(dir / "video.mp4"));
  ASSERT_TRUE(fs::exists(dir / "trajectory_truth.tum"));
  ASSERT_TRUE(fs::exists(dir / "simulate_options.json"));
  EXPECT_FALSE(fs::is_empty(dir / "stills"));

  VideoReader reader(dir / "video.mp4");
  EXPECT_EQ(reader.info().width, 320);
  int frames = 0;
  double mean_green = 0;
  while (auto f = reader.Next()) {
    ++frames;
    mean_green += cv::mean(f->bgr)[1];
  }
  EXPECT_EQ(frames, 30);
  EXPECT_GT(mean_green / frames, 20.0);  // a lit scene, not a black video

  const nlohmann::json truth = ReadJsonFile(dir / "truth.json");
  EXPECT_EQ(truth["frame_count"], 30);
  EXPECT_EQ(truth["poses"].size(), 30u);
  EXPECT_GT(truth["trees"].size(), 20u);
  EXPECT_FALSE(truth["saplings"].empty());

  // The truth written as a tree list scores perfectly, trajectory included.
  std::string csv = "tree_id,x_m,y_m,z_m,dbh_cm,dbh_sd_cm,distance_m,azimuth_deg,n_views,flags\n";
  for (const auto& t : truth["trees"]) {
    csv += std::to_string(t["id"].get<int>()) + "," + std::to_string(t["x_m"].get<double>()) + "," +
           std::to_string(t["y_m"].get<double>()) + ",0," +
           std::to_string(t["dbh_cm"].get<double>()) + ",0,0,0,0,\n";
  }
  WriteFileAtomic(dir / "trees.csv", csv);
  const eval::Evaluation e = eval::RunEvaluate(
      {}, {dir / "truth.json", dir / "trees.csv", dir / "trajectory_truth.tum", dir});
  EXPECT_DOUBLE_EQ(e.raw.recall, 1.0);
  EXPECT_NEAR(e.raw.dbh.mae_cm, 0.0, 1e-4);
  EXPECT_NEAR(e.trajectory.ate_rmse_m, 0.0, 1e-5);
  EXPECT_TRUE(fs::exists(dir / "evaluation.json"));

  // Same seed, same truth.
  sim::SimulateOptions o2 = o;
  o2.out_dir = dir / "again";
  o2.stills = 0;
  sim::RunSimulate(o2);
  EXPECT_EQ(ReadFileToString(dir / "truth.json"), ReadFileToString(dir / "again" / "truth.json"));
  EXPECT_EQ(ReadFileToString(dir / "video.mp4"), ReadFileToString(dir / "again" / "video.mp4"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace stemmap
