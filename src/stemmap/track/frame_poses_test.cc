#include "stemmap/track/frame_poses.h"

#include <gtest/gtest.h>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"
#include "stemmap/core/units.h"

namespace stemmap::track {
namespace {

// Keyframes every 2° on a 1 m arm; the frame halfway between two of them has wobbled by 0.5° and
// 8 mm, which interpolating the keyframes cannot know.
struct WobbleScene {
  PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 67.0);
  SparseMap map;
  std::vector<StampedPose> keyframes_axis;
  StampedPose between_truth;
  FrameObservations between;

  explicit WobbleScene(uint64_t seed) {
    Rng rng(seed);
    map.arm_from_cam = NominalArmFromCam();
    auto pose_at = [&](double phi) {
      const Eigen::Quaterniond rz(Eigen::AngleAxisd(phi, Eigen::Vector3d::UnitZ()));
      return Rigid3d{rz * map.arm_from_cam, Eigen::Vector3d(std::cos(phi), std::sin(phi), 0)};
    };
    for (int k = 0; k < 3; ++k) {
      const Rigid3d p = pose_at(k * 2.0 * kDeg);
      keyframes_axis.push_back({0.25 * k, p});
      map.cam_from_world.push_back(p.rotation.conjugate());
      map.centre_world.push_back(p.translation);
    }
    between_truth = {0.125, pose_at(1.0 * kDeg)};
    between_truth.world_from_cam.rotation =
        between_truth.world_from_cam.rotation *
        Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * kDeg, Eigen::Vector3d(1, 2, 0).normalized()));
    between_truth.world_from_cam.translation += Eigen::Vector3d(0.004, -0.005, 0.004);
    between.t_s = between_truth.t_s;
    const Rigid3d cam_from_world = between_truth.world_from_cam.Inverse();
    for (int i = 0; i < 300; ++i) {
      const double a = rng.Uniform(-0.5, 0.6), r = rng.Uniform(3, 15);
      const Eigen::Vector3d x(r * std::cos(a), r * std::sin(a), rng.Uniform(-1.3, 2.0));
      const Eigen::Vector3d p = cam_from_world * x;
      if (p.z() < 0.5) continue;
      const Eigen::Vector2d px =
          camera.ImageFromCam(p) + 0.3 * Eigen::Vector2d(rng.Normal(), rng.Normal());
      if (px.x() < 0 || px.y() < 0 || px.x() > 959 || px.y() > 539) continue;
      between.track.push_back(static_cast<int>(map.point_world.size()));
      between.px.push_back(px.cast<float>());
      map.point_world.push_back(x);
      // A few points the map lost, and a few bad tracks.
      map.point_valid.push_back(i % 10 != 3);
      if (i % 17 == 5) between.px.back() += Eigen::Vector2f(25.f, -12.f);
    }
  }
};

double RotationErrorDeg(const StampedPose& a, const StampedPose& b) {
  return a.world_from_cam.rotation.angularDistance(b.world_from_cam.rotation) / kDeg;
}

TEST(FramePoses, ResectionFollowsTheWobbleThatInterpolationMisses) {
  WobbleScene scene(3);
  FramePoseSummary s;
  const std::vector<StampedPose> out =
      RefineFramePoses(FramePoseOptions{}, BundleOptions{}, {scene.between}, scene.keyframes_axis,
                       scene.map, scene.camera, &s);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(s.refined, 1);
  const StampedPose interpolated = InterpolatePoses({0.125}, scene.keyframes_axis)[0];
  EXPECT_GT(RotationErrorDeg(interpolated, scene.between_truth), 0.45);
  EXPECT_LT(RotationErrorDeg(out[0], scene.between_truth), 0.05);
  EXPECT_LT(
      (out[0].world_from_cam.translation - scene.between_truth.world_from_cam.translation).norm(),
      0.004);
  EXPECT_NEAR(out[0].t_s, 0.125, 1e-12);
}

TEST(FramePoses, KeepsTheInterpolatedPoseWithTooFewPoints) {
  WobbleScene scene(4);
  scene.between.track.resize(8);
  scene.between.px.resize(8);
  FramePoseSummary s;
  const std::vector<StampedPose> out =
      RefineFramePoses(FramePoseOptions{}, BundleOptions{}, {scene.between}, scene.keyframes_axis,
                       scene.map, scene.camera, &s);
  EXPECT_EQ(s.interpolated, 1);
  const StampedPose interpolated = InterpolatePoses({0.125}, scene.keyframes_axis)[0];
  EXPECT_LT(RotationErrorDeg(out[0], interpolated), 1e-9);
}

TEST(FramePoses, InterpolationHoldsBeyondTheEnds) {
  std::vector<StampedPose> poses(2);
  poses[0].t_s = 1.0;
  poses[1].t_s = 2.0;
  poses[1].world_from_cam.translation = Eigen::Vector3d(2, 0, 0);
  const std::vector<StampedPose> out = InterpolatePoses({0.5, 1.25, 3.0}, poses);
  EXPECT_NEAR(out[0].world_from_cam.translation.x(), 0.0, 1e-12);
  EXPECT_NEAR(out[1].world_from_cam.translation.x(), 0.5, 1e-12);
  EXPECT_NEAR(out[2].world_from_cam.translation.x(), 2.0, 1e-12);
}

TEST(FramePoses, OptionsRejectBadValues) {
  EXPECT_NO_THROW(FramePoseOptions{}.Check());
  FramePoseOptions few;
  few.min_points = 5;
  EXPECT_THROW(few.Check(), InputError);
  FramePoseOptions loose;
  loose.inlier_px = 0.0;
  EXPECT_THROW(loose.Check(), InputError);
  FramePoseOptions jump;
  jump.max_change_deg = -1.0;
  EXPECT_THROW(jump.Check(), InputError);
}

}  // namespace
}  // namespace stemmap::track
