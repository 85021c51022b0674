// End to end: simulate a short plot, decode it, and score the truth against itself; calibrate a
// simulated phone from its checkerboard video.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "stemmap/calib/calibrate.h"
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

// The largest distance (px) between where two cameras put the same rays, over a grid that reaches
// to 5 % of the image's sides (a board held at arm's length covers no more: beyond it the fitted
// lens is an extrapolation).
double LargestImageDistancePx(const PinholeCamera& truth, const PinholeCamera& estimate) {
  double largest = 0.0;
  for (int i = 0; i <= 10; ++i) {
    for (int j = 0; j <= 10; ++j) {
      const Eigen::Vector2d px((0.05 + 0.09 * i) * truth.width, (0.05 + 0.09 * j) * truth.height);
      const Eigen::Vector3d ray = truth.CamRayFromImage(px);
      largest = std::max(largest, (estimate.ImageFromCam(ray) - px).norm());
    }
  }
  return largest;
}

// A forester calibrates the 0.5x wide camera once from a video of a printed board: the simulated
// board video of the `wide` preset's lens gives that lens back, its strong barrel included.
TEST(EndToEnd, AWideLensIsCalibratedFromItsBoardVideo) {
  const fs::path dir = fs::temp_directory_path() / ("stemmap_board_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  sim::SimulateOptions o;
  o.seed = 12;
  o.out_dir = dir;
  o.width = 640;
  o.height = 360;
  o.checkerboard = true;
  sim::ApplyPhonePreset(sim::PhonePreset::kWide, &o);
  sim::RunSimulate(o);
  const PinholeCamera truth = ReadJsonFile(dir / "board_truth.json")["intrinsics"];
  calib::CalibrateOptions co;
  co.lens = calib::LensKind::kWide;
  const calib::CalibrateSummary wide =
      calib::RunCalibrate(co, dir / "video.mp4", dir / "wide.yaml");
  EXPECT_GE(wide.views, 30);
  EXPECT_LT(wide.rms_px, 0.3);
  EXPECT_NEAR(wide.camera.fx / truth.fx, 1.0, 0.005);
  EXPECT_LT(LargestImageDistancePx(truth, wide.camera), 1.0);
  // The file a run reads gives the same camera.
  const PinholeCamera read = calib::ReadCalibration(dir / "wide.yaml", truth.width, truth.height);
  EXPECT_LT(LargestImageDistancePx(truth, read), 1.0);
  // Without k3 the corners of so wide a lens are off by more.
  co.lens = calib::LensKind::kMain;
  const calib::CalibrateSummary main =
      calib::RunCalibrate(co, dir / "video.mp4", dir / "main.yaml");
  EXPECT_GT(LargestImageDistancePx(truth, main.camera), LargestImageDistancePx(truth, wide.camera));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace stemmap
