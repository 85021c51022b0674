#include "stemmap/camera/camera.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

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

// A phone's wide camera: about 100° across through a strong barrel distortion.
PinholeCamera WideLens() {
  return PinholeCamera::FromLensHfov(960, 540, 100.0, -0.25, 0.07, -0.008);
}

TEST(PinholeCamera, WideLensRoundTripsOverTheWholeImage) {
  const PinholeCamera c = WideLens();
  EXPECT_NO_THROW(c.Check());
  EXPECT_NEAR(c.LensHfovDeg(), 100.0, 1e-9);
  EXPECT_LT(c.HfovDeg(), 90.0);  // the pinhole part alone sees less
  double worst_px = 0.0;
  for (int v = 0; v < c.height; v += 3) {
    for (int u = 0; u < c.width; u += 3) {
      for (const Eigen::Vector2d& px :
           {Eigen::Vector2d(u, v), Eigen::Vector2d(u + 0.37, v + 0.81)}) {
        const Eigen::Vector2d back = c.ImageFromCam(c.CamRayFromImage(px) * 2.5);
        worst_px = std::max(worst_px, (back - px).norm());
      }
    }
  }
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(959.5, 539.5), Eigen::Vector2d(-0.5, 539.5),
        Eigen::Vector2d(959.5, -0.5)}) {
    worst_px = std::max(worst_px, (c.ImageFromCam(c.CamRayFromImage(corner)) - corner).norm());
  }
  EXPECT_LT(worst_px, 1e-6);
  // The corners see well beyond the edges' 50°.
  const Eigen::Vector3d corner_ray = c.CamRayFromImage({-0.5, -0.5});
  EXPECT_GT(std::atan(corner_ray.head<2>().norm()) * 180.0 / std::numbers::pi, 54.0);
}

TEST(PinholeCamera, CheckRefusesALensThatFoldsOver) {
  PinholeCamera c = WideLens();
  c.k2 = 0.0;
  c.k3 = 0.0;  // k1 alone: r (1 - 0.25 r²) stops growing 49° off the axis, inside the image
  EXPECT_THROW(c.Check(), InputError);
  c = WideLens();
  c.k3 = 2.0;  // beyond any lens
  EXPECT_THROW(c.Check(), InputError);
  c = WideLens();
  c.k1 = std::nan("");
  EXPECT_THROW(c.Check(), InputError);
  // A field whose edges lie beyond the fold cannot be asked of a lens.
  EXPECT_THROW(PinholeCamera::FromLensHfov(960, 540, 110.0, -0.3, 0.0, 0.0), InputError);
  EXPECT_NO_THROW(PinholeCamera::FromLensHfov(960, 540, 60.0, -0.3, 0.0, 0.0).Check());
  // The same mild lens as before is fine, and a narrow image of the folding lens is too: the
  // fold lies beyond its corners.
  PinholeCamera narrow = PinholeCamera::FromHfov(960, 540, 60.0);
  narrow.k1 = -0.25;
  EXPECT_NO_THROW(narrow.Check());
}

TEST(PinholeCamera, K3IsSavedOnlyWhereUsed) {
  const PinholeCamera wide = WideLens();
  const nlohmann::json j = wide;
  EXPECT_EQ(j.at("k3").get<double>(), -0.008);
  EXPECT_EQ(j.get<PinholeCamera>().k3, -0.008);
  const nlohmann::json plain = PinholeCamera::FromHfov(640, 360, 60.0);
  EXPECT_FALSE(plain.contains("k3"));
  EXPECT_EQ(plain.get<PinholeCamera>().k3, 0.0);
  EXPECT_EQ(wide.Scaled(0.5).k3, -0.008);
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
