#include "stemmap/sim/simulate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <sstream>
#include <string>

#include "stemmap/core/io.h"
#include "stemmap/core/units.h"

namespace stemmap::sim {
namespace {

namespace fs = std::filesystem;

nlohmann::json TruthOf(double start_deg, double dx, double dy, const std::string& name) {
  SimulateOptions o;
  o.seed = 4;
  o.kind = StandKind::kNatural;
  o.truth_only = true;
  o.fps = 5;
  o.start_deg = start_deg;
  o.centre_offset_x_m = dx;
  o.centre_offset_y_m = dy;
  o.out_dir = fs::path(::testing::TempDir()) / ("stemmap_simulate_" + name);
  RunSimulate(o);
  return ReadJsonFile(o.out_dir / "truth.json");
}

// Another capture of the same stand: the same trees, each where the tripod's offset and the
// first view's turn put it in the new plot frame.
TEST(Simulate, AnotherStartAndCentreCaptureTheSameStand) {
  const nlohmann::json base = TruthOf(0.0, 0.0, 0.0, "base");
  const nlohmann::json moved = TruthOf(75.0, 1.2, -0.6, "moved");
  EXPECT_NEAR(moved["stand_from_plot"]["yaw_deg"].get<double>(), 75.0, 1e-9);
  EXPECT_NEAR(moved["stand_from_plot"]["x_m"].get<double>(), 1.2, 1e-12);
  std::map<int, nlohmann::json> stand;
  for (const auto& t : base["trees"]) stand[t["id"].get<int>()] = t;
  ASSERT_EQ(moved["trees"].size(), base["trees"].size());
  const double c = std::cos(75.0 * kDeg), s = std::sin(75.0 * kDeg);
  const double ground_z = moved["stand_from_plot"]["z_m"].get<double>();
  for (const auto& t : moved["trees"]) {
    const nlohmann::json& b = stand.at(t["id"].get<int>());
    const double x = b["x_m"].get<double>() - 1.2, y = b["y_m"].get<double>() + 0.6;
    EXPECT_NEAR(t["x_m"].get<double>(), c * x + s * y, 1e-9);
    EXPECT_NEAR(t["y_m"].get<double>(), -s * x + c * y, 1e-9);
    EXPECT_NEAR(t["z_m"].get<double>(), b["z_m"].get<double>() - ground_z, 1e-9);
    EXPECT_NEAR(t["dbh_cm"].get<double>(), b["dbh_cm"].get<double>(), 1e-12);
    EXPECT_NEAR(t["distance_m"].get<double>(), std::hypot(x, y), 1e-9);
  }
  // The rig itself is the same capture in its own frame: the first view along x.
  EXPECT_EQ(moved["poses"][0]["t_xyz"], base["poses"][0]["t_xyz"]);
}

// A phone's effects recorded with the truth: every option in the camera section, and each
// frame's intrinsics in frames_truth.csv as the autofocus and the stabilising crop set them.
TEST(Simulate, PhoneEffectsGoIntoTheTruth) {
  SimulateOptions o;
  o.seed = 4;
  o.kind = StandKind::kNatural;
  o.truth_only = true;
  o.width = 320;
  o.height = 180;
  o.fps = 10;
  o.seconds = 6;
  ApplyPhonePreset(PhonePreset::kMain, &o);
  o.phone.stabilisation = true;
  o.out_dir = fs::path(::testing::TempDir()) / "stemmap_simulate_phone";
  fs::remove_all(o.out_dir);
  RunSimulate(o);
  const nlohmann::json truth = ReadJsonFile(o.out_dir / "truth.json");
  const nlohmann::json& cam = truth.at("intrinsics");
  EXPECT_EQ(cam.at("phone").at("preset"), "main");
  EXPECT_EQ(cam.at("phone").at("readout_ms").get<double>(), 25.0);
  EXPECT_EQ(cam.at("distortion")[1].get<double>(), -0.01);
  EXPECT_EQ(ReadJsonFile(o.out_dir / "simulate_options.json").at("phone").at("breathing_pct"), 0.7);
  const double fx0 = cam.at("fx").get<double>(), cx0 = cam.at("cx").get<double>();
  const std::string csv = ReadFileToString(o.out_dir / "frames_truth.csv");
  std::istringstream lines(csv);
  std::string line;
  std::getline(lines, line);
  EXPECT_EQ(line, "frame,t_s,fx,fy,cx,cy,focus_m");
  int rows = 0;
  double mean_dcx = 0.0, min_fx = 1e9, max_fx = 0.0;
  while (std::getline(lines, line)) {
    double v[7];
    std::istringstream fields(line);
    for (double& x : v) {
      std::string f;
      std::getline(fields, f, ',');
      x = std::stod(f);
    }
    EXPECT_EQ(v[0], rows);
    EXPECT_NEAR(v[2] / fx0, BreathingScale(v[6], 0.7), 1e-12);  // breathing from the focus
    EXPECT_EQ(v[2], v[3]);
    min_fx = std::min(min_fx, v[2]);
    max_fx = std::max(max_fx, v[2]);
    mean_dcx += v[4] - cx0;
    ++rows;
  }
  EXPECT_EQ(rows, truth.at("frame_count").get<int>());
  EXPECT_GE(min_fx, fx0 * 0.993 - 1e-9);
  EXPECT_LE(max_fx, fx0 * 1.007 + 1e-9);
  EXPECT_LT(std::abs(mean_dcx / rows), 1.0);  // px: the crop's shifts average out

  // Still air and an ideal camera write the truth as before: no phone section, no per-frame file.
  SimulateOptions plain = o;
  ApplyPhonePreset(PhonePreset::kIdeal, &plain);
  plain.out_dir = fs::path(::testing::TempDir()) / "stemmap_simulate_ideal";
  fs::remove_all(plain.out_dir);
  RunSimulate(plain);
  EXPECT_FALSE(ReadJsonFile(plain.out_dir / "truth.json").at("intrinsics").contains("phone"));
  EXPECT_FALSE(fs::exists(plain.out_dir / "frames_truth.csv"));
}

TEST(Simulate, RefusesACentreOffTheStand) {
  SimulateOptions o;
  o.out_dir = fs::path(::testing::TempDir()) / "stemmap_simulate_far";
  o.centre_offset_x_m = 12.0;
  EXPECT_THROW(o.Check(), InputError);
}

// A tripod levelled with its bubble: the stand's tilt as given, everything else the seed's.
TEST(Simulate, AGivenStandTiltKeepsTheSeedsOtherDraws) {
  SimulateOptions o;
  o.seed = 4;
  o.truth_only = true;
  o.fps = 5;
  o.out_dir = fs::path(::testing::TempDir()) / "stemmap_simulate_tilt";
  RunSimulate(o);
  const nlohmann::json drawn = ReadJsonFile(o.out_dir / "truth.json");
  o.stand_tilt_deg = 0.1;
  RunSimulate(o);
  const nlohmann::json levelled = ReadJsonFile(o.out_dir / "truth.json");
  EXPECT_DOUBLE_EQ(levelled["rig"]["stand_tilt_deg"].get<double>(), 0.1);
  EXPECT_NE(drawn["rig"]["stand_tilt_deg"].get<double>(), 0.1);
  EXPECT_EQ(levelled["rig"]["mount_roll_deg"], drawn["rig"]["mount_roll_deg"]);
  EXPECT_EQ(levelled["camera_height_m"], drawn["camera_height_m"]);
  o.stand_tilt_deg = 12.0;
  EXPECT_THROW(o.Check(), InputError);
  o.stand_tilt_deg = std::nan("");
  EXPECT_THROW(o.Check(), InputError);
}

// A board video has no plot truth to write alone.
TEST(Simulate, RefusesABoardVideoWithTruthOnly) {
  SimulateOptions o;
  o.out_dir = fs::path(::testing::TempDir()) / "stemmap_simulate_board";
  o.checkerboard = true;
  EXPECT_NO_THROW(o.Check());
  o.truth_only = true;
  try {
    o.Check();
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--checkerboard"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace stemmap::sim
