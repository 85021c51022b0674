#include "stemmap/sim/render.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "stemmap/sim/rig.h"
#include "stemmap/sim/sensor.h"
#include "stemmap/sim/wind.h"

namespace stemmap::sim {
namespace {

// The layout's one stem, smooth and upright on flat ground, 4 m ahead of a level camera at the
// origin (its parameters in `stem`).
Scene OneStemScene(StemParams* stem) {
  SceneOptions o;
  o.layout = {{4.0, 0.0, 40.0}};
  o.seed = 5;
  Scene scene = GenerateScene(o);
  scene.trees.erase(scene.trees.begin() + 1, scene.trees.end());
  scene.shrubs.clear();
  StemParams p = scene.trees[0].stem.params();
  p.lean_rad = 0;
  p.axis_ratio = 1.0;
  p.furrow_depth_m = 0;
  p.base_world = {4.0, 0.0, scene.ground.Height(4.0, 0.0)};
  scene.trees[0] = SceneTree(p);
  *stem = p;
  return scene;
}

// One stem 4 m in front of a level camera at the origin: it must appear where projection says,
// with the right width, and the render must be deterministic.
TEST(Renderer, StemAppearsWhereTheCameraModelPutsIt) {
  StemParams p;
  const Scene scene = OneStemScene(&p);
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

Rigid3d LookingAlongX() {
  Eigen::Matrix3d r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return {Eigen::Quaterniond(r), {0, 0, 1.3}};
}

// The stem's left side in row v: the first column that sees it (depth under 4.5 m).
int LeftSide(const RenderBuffers& b, int v) {
  for (int u = 0; u < b.depth_m.cols; ++u) {
    if (b.depth_m.at<float>(v, u) < 4.5f) return u;
  }
  return -1;
}

// A rolling shutter reads the rows while the camera turns: a vertical stem leans in the image by
// the turn over the readout, rate × readout × fx over the whole height; without one, it stands.
TEST(Renderer, RollingShutterSlantsAStemByTheTurnOverTheReadout) {
  StemParams p;
  const Scene scene = OneStemScene(&p);
  const PinholeCamera cam = PinholeCamera::FromHfov(320, 180, 60.0);
  const Renderer renderer(scene, cam, RenderOptions{});
  const double rate_rad_s = 1.0;  // turning left, counter-clockwise seen from above
  const auto render = [&](double readout_s) {
    FrameSetup frame;
    frame.world_from_cam = LookingAlongX();
    for (int v = 0; v < cam.height; ++v) {
      const double t_s = readout_s * (static_cast<double>(v) / (cam.height - 1) - 0.5);
      Rigid3d pose = frame.world_from_cam;
      pose.rotation = Eigen::AngleAxisd(rate_rad_s * t_s, Eigen::Vector3d::UnitZ()) * pose.rotation;
      frame.world_from_row_cam.push_back(pose);
    }
    return renderer.Render(frame);
  };
  const int v0 = 40, v1 = 140;
  const RenderBuffers still = render(0.0);
  const RenderBuffers rolling = render(0.05);
  // With a readout of 0 every row has the frame's pose: the global shutter's image exactly.
  const RenderBuffers global = renderer.Render(LookingAlongX());
  EXPECT_EQ(cv::norm(still.radiance, global.radiance, cv::NORM_INF), 0.0);
  const int slant_still = LeftSide(still, v1) - LeftSide(still, v0);
  const int slant_rolling = LeftSide(rolling, v1) - LeftSide(rolling, v0);
  EXPECT_LE(std::abs(slant_still), 1);
  // Later rows see the camera turned further left, so the stem further right.
  const double expected_px = cam.fx * rate_rad_s * 0.05 * (v1 - v0) / (cam.height - 1);
  EXPECT_NEAR(slant_rolling - slant_still, expected_px, 1.5);
  // The middle row is the frame's own pose: it sees the stem where the global shutter does.
  const int mid = (cam.height - 1) / 2;
  EXPECT_LE(std::abs(LeftSide(rolling, mid) - LeftSide(global, mid)), 1);
}

// Effects explicitly at zero (every row at the frame's pose, the frame's camera the renderer's,
// still air) render the very image of the plain call.
TEST(Renderer, EffectsAtZeroRenderTheSameImage) {
  SceneOptions o;
  o.kind = StandKind::kNatural;
  o.seed = 3;
  const Scene scene = GenerateScene(o);
  const PinholeCamera cam = PinholeCamera::FromHfov(160, 90, 65.0);
  const Renderer renderer(scene, cam, RenderOptions{});
  const RenderBuffers plain = renderer.Render(LookingAlongX());
  FrameSetup frame;
  frame.world_from_cam = LookingAlongX();
  frame.world_from_row_cam.assign(cam.height, frame.world_from_cam);
  frame.camera = cam;
  frame.sway = Wind(scene, 0.0, 3).At(1.0);
  const RenderBuffers zero = renderer.Render(frame);
  EXPECT_EQ(cv::norm(plain.radiance, zero.radiance, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(plain.depth_m, zero.depth_m, cv::NORM_INF), 0.0);
}

// In wind a shrub and a sapling move between frames of a still camera; the tree's stem at breast
// height does not, to the last bit.
TEST(Renderer, WindMovesShrubsAndSaplingsNotStems) {
  StemParams p;
  Scene scene = OneStemScene(&p);
  StemParams sapling = p;
  sapling.radius_bh_m = 0.02;
  sapling.flare = 0.05;
  sapling.height_m = 4.0;
  sapling.base_world = {3.0, -0.8, scene.ground.Height(3.0, -0.8)};
  scene.trees.emplace_back(sapling);
  scene.trees.back().sapling = true;
  scene.trees.back().id = 2;
  Shrub shrub;
  shrub.centre = {3.0, 0.9, scene.ground.Height(3.0, 0.9) + 0.5};
  shrub.radii_m = {0.4, 0.4, 0.5};
  shrub.density = 0.6;
  shrub.seed = 77;
  scene.shrubs.push_back(shrub);
  const PinholeCamera cam = PinholeCamera::FromHfov(320, 180, 60.0);
  const Renderer renderer(scene, cam, RenderOptions{});
  const Wind wind(scene, 1.0, 11);
  const auto render = [&](double t_s) {
    FrameSetup frame;
    frame.world_from_cam = LookingAlongX();
    frame.sway = wind.At(t_s);
    return renderer.Render(frame);
  };
  const RenderBuffers a = render(0.0), b = render(0.7);
  // Where the shrub (left of the stem) and the sapling (right of it) are.
  const Eigen::Vector2d shrub_px = cam.ImageFromCam(LookingAlongX().Inverse() * shrub.centre);
  const Eigen::Vector2d sapling_px =
      cam.ImageFromCam(LookingAlongX().Inverse() * Eigen::Vector3d(3.0, -0.8, 1.3));
  const auto changed = [&](const Eigen::Vector2d& px, int half) {
    int n = 0;
    for (int v = std::max(0, static_cast<int>(px.y()) - half);
         v <= std::min(cam.height - 1, static_cast<int>(px.y()) + half); ++v) {
      for (int u = std::max(0, static_cast<int>(px.x()) - half);
           u <= std::min(cam.width - 1, static_cast<int>(px.x()) + half); ++u) {
        n += a.depth_m.at<float>(v, u) != b.depth_m.at<float>(v, u);
      }
    }
    return n;
  };
  EXPECT_GT(changed(shrub_px, 20), 20);
  EXPECT_GT(changed(sapling_px, 6), 2);
  // The stem's breast height (1.37 m, a few rows above the middle), across the stem and a few
  // pixels either side: identical colours and depths.
  const int v_bh = static_cast<int>(std::lround(cam.cy - cam.fy * (kBreastHeightM - 1.3) / 4.0));
  const int half_px = static_cast<int>(cam.fx * p.radius_bh_m / 4.0) + 4;
  const cv::Rect bh(static_cast<int>(cam.cx) - half_px, v_bh - 3, 2 * half_px + 1, 7);
  EXPECT_EQ(cv::norm(a.radiance(bh), b.radiance(bh), cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.depth_m(bh), b.depth_m(bh), cv::NORM_INF), 0.0);
  // At strength 1 a sapling's top sways by centimetres, a shrub by about 5 cm at most.
  for (double t_s = 0.0; t_s < 4.0; t_s += 0.25) {
    const SceneSway sway = wind.At(t_s);
    EXPECT_LE(sway.shrub_offset_m[0].norm(), 1.1 * Wind::kShrubSwayM);
    EXPECT_EQ(sway.tree_tilt[0].vec().norm(), 0.0);  // the tree stands still
    const double top_m = Eigen::AngleAxisd(sway.tree_tilt[1]).angle() * sapling.height_m;
    EXPECT_LE(top_m, 1.1 * Wind::kSaplingTiltRad * sapling.height_m);
  }
}

}  // namespace
}  // namespace stemmap::sim
