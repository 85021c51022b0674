#include "stemmap/sim/render.h"

#include <gtest/gtest.h>

#include <stdexcept>

#include "stemmap/sim/rig.h"
#include "stemmap/sim/sensor.h"

namespace stemmap::sim {
namespace {

// One stem 4 m in front of a level camera at the origin: it must appear where projection says,
// with the right width, and the render must be deterministic.
TEST(Renderer, StemAppearsWhereTheCameraModelPutsIt) {
  SceneOptions o;
  o.layout = {{4.0, 0.0, 40.0}};
  o.seed = 5;
  Scene scene = GenerateScene(o);
  // Keep only the layout stem, make it smooth and upright, on flat ground.
  scene.trees.erase(scene.trees.begin() + 1, scene.trees.end());
  scene.shrubs.clear();
  StemParams p = scene.trees[0].stem.params();
  p.lean_rad = 0;
  p.axis_ratio = 1.0;
  p.furrow_depth_m = 0;
  p.base_world = {4.0, 0.0, scene.ground.Height(4.0, 0.0)};
  scene.trees[0] = SceneTree(p);
  const PinholeCamera cam = PinholeCamera::FromHfov(320, 180, 60.0);
  const Renderer renderer(scene, cam, RenderOptions{});
  Rigid3d world_from_cam;
  Eigen::Matrix3d r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  world_from_cam.rotation = Eigen::Quaterniond(r);
  world_from_cam.translation = {0, 0, 1.3};
  const RenderBuffers a = renderer.Render(world_from_cam);
  const RenderBuffers b = renderer.Render(world_from_cam);
  EXPECT_EQ(cv::norm(a.radiance, b.radiance, cv::NORM_INF), 0.0);
  // Row through the camera centre: depth ~ distance to the stem surface over the expected width.
  const int v = static_cast<int>(cam.cy);
  const double r_stem = p.radius_bh_m + p.taper_m_per_m * (p.s_bh_m - 1.3 + p.base_world.z());
  const double half_px = cam.fx * std::asin(r_stem / 4.0);
  int near = 0;
  for (int u = 0; u < cam.width; ++u) near += a.depth_m.at<float>(v, u) < 4.5f;
  EXPECT_NEAR(near, 2.0 * half_px, 2.0);
  EXPECT_NEAR(a.depth_m.at<float>(v, static_cast<int>(cam.cx)), 4.0 - r_stem, 0.01);

  // Antialiasing touches one pixel per stem side and row: the one whose footprint holds the side.
  RenderOptions no_aa;
  no_aa.antialias = false;
  const RenderBuffers c = Renderer(scene, cam, no_aa).Render(world_from_cam);
  int changed = 0;
  for (int u = 0; u < cam.width; ++u) {
    if (cv::norm(a.radiance.at<cv::Vec3f>(v, u) - c.radiance.at<cv::Vec3f>(v, u)) == 0) continue;
    ++changed;
    const double side_px =
        std::min(std::abs(u - (cam.cx - half_px)), std::abs(u - (cam.cx + half_px)));
    EXPECT_LE(side_px, 1.0) << "column " << u;
  }
  EXPECT_GE(changed, 1);
  EXPECT_LE(changed, 2);

  SensorModel sensor(SensorParams{}, cam);
  const cv::Mat bgr = sensor.Capture(a, 0.15, 1.0, 0, 1.0 / 30);
  EXPECT_EQ(bgr.type(), CV_8UC3);
  EXPECT_GT(cv::mean(bgr)[1], 10.0);  // not black

  // A frame of another size than the camera's is refused, not read past its end.
  RenderBuffers small;
  small.radiance = cv::Mat(90, 160, CV_32FC3, cv::Scalar::all(0.1));
  small.depth_m = cv::Mat(90, 160, CV_32F, cv::Scalar(5.0));
  try {
    sensor.Capture(small, 0.15, 1.0, 1, 1.0 / 30);
    ADD_FAILURE() << "a 160x90 frame for a 320x180 camera was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "sensor: frame size differs from the camera's");
  }
}

}  // namespace
}  // namespace stemmap::sim
