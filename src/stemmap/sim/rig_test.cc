#include "stemmap/sim/rig.h"

#include <gtest/gtest.h>

#include <numbers>

namespace stemmap::sim {
namespace {

TEST(Rig, CameraCirclesTheAxisFacingOutward) {
  RigParams p;
  p.seconds = 10;
  p.fps = 10;
  p.turns = 1.0;
  p.stand_tilt_deg = 0.0;
  p.wobble_m = 0.0;
  p.wobble_deg = 0.0;
  const auto frames = SimulateRig(p);
  ASSERT_EQ(frames.size(), 100u);
  // First frame looks along +x and stands on the circle.
  const Eigen::Vector3d view0 = frames[0].world_from_cam.rotation * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(view0.y(), 0.0, 1e-9);
  EXPECT_GT(view0.x(), 0.99);
  double swept = 0.0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const Eigen::Vector3d c = frames[i].world_from_cam.translation;
    EXPECT_NEAR(c.head<2>().norm(), 1.0, 1e-9);
    EXPECT_NEAR(c.z(), p.camera_height_m, 1e-9);
    const Eigen::Vector3d view = frames[i].world_from_cam.rotation * Eigen::Vector3d::UnitZ();
    EXPECT_GT(view.head<2>().dot(c.head<2>().normalized()), 0.99);  // outward
    const Eigen::Vector3d down = frames[i].world_from_cam.rotation * Eigen::Vector3d::UnitY();
    EXPECT_LT(down.z(), -0.99);
    if (i > 0) swept += std::abs(frames[i].yaw_rate_rad_s) / p.fps;
  }
  EXPECT_NEAR(swept, 2 * std::numbers::pi, 0.1);
}

TEST(Rig, TiltAndWobbleStaySmall) {
  RigParams p;
  p.seconds = 5;
  p.stand_tilt_deg = 1.5;
  p.seed = 9;
  for (const RigFrame& f : SimulateRig(p)) {
    EXPECT_NEAR(f.world_from_cam.translation.head<2>().norm(), 1.0, 0.05);
    EXPECT_NEAR(f.world_from_cam.translation.z(), p.camera_height_m, 0.05);
  }
}

}  // namespace
}  // namespace stemmap::sim
