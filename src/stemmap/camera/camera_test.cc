#include "stemmap/camera/camera.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "stemmap/core/error.h"

namespace stemmap {
namespace {

TEST(PinholeCamera, HfovRoundTrip) {
  const PinholeCamera c = PinholeCamera::FromHfov(1920, 1080, 65.0);
  EXPECT_NEAR(c.HfovDeg(), 65.0, 1e-9);
  EXPECT_NEAR(c.fx, 1507.0, 1.0);
}

TEST(PinholeCamera, ProjectUnprojectWithDistortion) {
  PinholeCamera c = PinholeCamera::FromHfov(960, 540, 70.0);
  c.k1 = -0.04;
  c.k2 = 0.01;
  for (double u : {0.0, 100.0, 480.0, 959.0}) {
    for (double v : {0.0, 270.0, 539.0}) {
      const Eigen::Vector3d ray = c.CamRayFromImage({u, v});
      const Eigen::Vector2d back = c.ImageFromCam(ray * 3.7);
      EXPECT_NEAR(back.x(), u, 1e-6);
      EXPECT_NEAR(back.y(), v, 1e-6);
    }
  }
}

TEST(PinholeCamera, ScaledKeepsRays) {
  const PinholeCamera c = PinholeCamera::FromHfov(1920, 1080, 65.0);
  const PinholeCamera h = c.Scaled(0.5);
  EXPECT_EQ(h.width, 960);
  // The same ray hits pixel u in the full image and (u + 0.5) / 2 - 0.5 in the half image.
  const Eigen::Vector3d ray = c.CamRayFromImage({100.0, 200.0});
  const Eigen::Vector2d px = h.ImageFromCam(ray);
  EXPECT_NEAR(px.x(), 100.5 / 2 - 0.5, 1e-9);
  EXPECT_NEAR(px.y(), 200.5 / 2 - 0.5, 1e-9);
}

TEST(PinholeCamera, CheckAndJson) {
  PinholeCamera c = PinholeCamera::FromHfov(640, 360, 60.0);
  nlohmann::json j = c;
  EXPECT_EQ(j.get<PinholeCamera>().fx, c.fx);
  c.fx = -1;
  EXPECT_THROW(c.Check(), InputError);
}

}  // namespace
}  // namespace stemmap
