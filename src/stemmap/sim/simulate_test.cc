#include "stemmap/sim/simulate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

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

TEST(Simulate, RefusesACentreOffTheStand) {
  SimulateOptions o;
  o.out_dir = fs::path(::testing::TempDir()) / "stemmap_simulate_far";
  o.centre_offset_x_m = 12.0;
  EXPECT_THROW(o.Check(), InputError);
}

}  // namespace
}  // namespace stemmap::sim
