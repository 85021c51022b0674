#include "stemmap/track/refine_observations.h"

#include <gtest/gtest.h>

#include "stemmap/core/rng.h"

namespace stemmap::track {
namespace {

// Smooth random texture (a sum of waves with periods of 5-20 px, like bark or litter at the
// working resolution), moved by (dx, dy) px and brightened by gain and offset, computed exactly.
cv::Mat Texture(uint64_t seed, int w, int h, double dx = 0, double dy = 0, double gain = 1,
                double offset = 0) {
  Rng rng(seed);
  struct Wave {
    double kx, ky, phase;
  };
  std::vector<Wave> waves;
  for (int i = 0; i < 12; ++i) {
    const double angle = rng.Uniform(0, M_PI), k = 2 * M_PI / rng.Uniform(5, 20);
    waves.push_back({k * std::cos(angle), k * std::sin(angle), rng.Uniform(0, 2 * M_PI)});
  }
  cv::Mat out(h, w, CV_8U);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      double g = 110;
      for (const Wave& q : waves) g += 7.0 * std::sin(q.kx * (u - dx) + q.ky * (v - dy) + q.phase);
      out.at<uchar>(v, u) = cv::saturate_cast<uchar>(gain * g + offset);
    }
  }
  return out;
}

TEST(RefineObservations, AlignPatchFindsASubpixelShiftUnderAnExposureChange) {
  const cv::Mat ref = Texture(3, 160, 120);
  const cv::Mat img = Texture(3, 160, 120, 0.37, -0.28, 1.1, 6.0);
  RefineObservationsOptions o;
  const Eigen::Vector2d ref_px(80, 60);
  Eigen::Vector2d px = ref_px;  // where KLT left it: off by the shift
  double ncc = 0;
  ASSERT_TRUE(AlignPatch(o, ref, ref_px, img, Eigen::Matrix2d::Identity(), &px, &ncc));
  EXPECT_NEAR(px.x(), 80.37, 0.05);  // bilinear sampling of 5-px waves costs a few hundredths
  EXPECT_NEAR(px.y(), 59.72, 0.05);
  EXPECT_GT(ncc, 0.98);
}

TEST(RefineObservations, AlignPatchRefusesAFlatReference) {
  const cv::Mat flat(120, 160, CV_8U, cv::Scalar(128));
  RefineObservationsOptions o;
  Eigen::Vector2d px(80, 60);
  double ncc = 0;
  EXPECT_FALSE(AlignPatch(o, flat, {80, 60}, flat, Eigen::Matrix2d::Identity(), &px, &ncc));
  // A patch that would leave the image is refused too.
  const cv::Mat ref = Texture(4, 160, 120);
  px = {1.5, 60};
  EXPECT_FALSE(AlignPatch(o, ref, {1.5, 60}, ref, Eigen::Matrix2d::Identity(), &px, &ncc));
}

TEST(RefineObservations, PatchWarpScalesWithTheDistanceToThePoint) {
  const PinholeCamera camera = PinholeCamera::FromHfov(640, 360, 60.0);
  SparseMap map;
  // Both cameras look along +x (OpenCV axes: z forward); the second stands halfway to the point.
  const Eigen::Matrix3d world_from_cam =
      (Eigen::Matrix3d() << 0, 0, 1, -1, 0, 0, 0, -1, 0).finished();
  const Eigen::Quaterniond cam_from_world(world_from_cam.transpose());
  map.cam_from_world = {cam_from_world, cam_from_world};
  map.centre_world = {Eigen::Vector3d::Zero(), Eigen::Vector3d(2, 0, 0)};
  Eigen::Matrix2d a;
  ASSERT_TRUE(LocalPatchWarp(map, camera, 0, 1, Eigen::Vector3d(4, 0.1, 0.05), &a));
  EXPECT_NEAR(a(0, 0), 2.0, 2e-3);
  EXPECT_NEAR(a(1, 1), 2.0, 2e-3);
  EXPECT_NEAR(a(0, 1), 0.0, 2e-3);
  EXPECT_NEAR(a(1, 0), 0.0, 2e-3);
  // A point behind the second camera has no warp.
  EXPECT_FALSE(LocalPatchWarp(map, camera, 0, 1, Eigen::Vector3d(1, 0, 0), &a));
}

TEST(RefineObservations, FramesBetweenKeyframesTakeTheInterpolatedCorrection) {
  std::vector<Keyframe> keyframes(3);
  keyframes[0].frame = 0;
  keyframes[1].frame = 10;
  keyframes[2].frame = 20;
  const std::vector<Track> before = {{{{0, {10, 10}}, {1, {20, 10}}}}};
  const std::vector<Track> after = {{{{0, {11, 10}}, {1, {23, 9}}}}};
  std::vector<FrameObservations> between(3);
  for (int i = 0; i < 3; ++i) {
    between[i].frame = std::vector<int>{5, 15, 0}[i];
    between[i].track = {0};
    between[i].px = {Eigen::Vector2f(15, 10)};
  }
  CarryCorrectionsToFrames(before, after, keyframes, &between);
  EXPECT_NEAR(between[0].px[0].x(), 17.0, 2e-3);  // halfway: (1 + 3) / 2
  EXPECT_NEAR(between[0].px[0].y(), 9.5, 2e-3);
  EXPECT_NEAR(between[1].px[0].x(), 18.0, 2e-3);  // after the last keyframe: its correction
  EXPECT_NEAR(between[2].px[0].x(), 16.0, 2e-3);  // at the first keyframe: its correction
}

// Under a rolling shutter a point's picture lies off its frame-time place by its row's shift, which
// differs from keyframe to keyframe (the point's speed across the picture changes): the patches
// are matched where the pictures show the point and the refined place keeps its own shift.
TEST(RefineObservations, PatchesAreMatchedWhereTheRollingShutterShowsThem) {
  const PinholeCamera camera = PinholeCamera::FromHfov(160, 120, 60.0);
  SparseMap map;
  // Two keyframes at one pose: the patch warp is the identity.
  const Eigen::Quaterniond cam_from_world = Eigen::Quaterniond::Identity();
  map.cam_from_world = {cam_from_world, cam_from_world};
  map.centre_world = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  map.point_world = {Eigen::Vector3d(0, 0, 4)};
  map.point_valid = {1};
  map.obs_valid = {{1, 1}};
  const Eigen::Vector2d at_frame_time(80, 60);
  const Eigen::Vector2d shift0(0.6, 0.2), shift1(-0.4, -0.1);
  const std::vector<cv::Mat> gray = {Texture(5, 160, 120, shift0.x(), shift0.y()),
                                     Texture(5, 160, 120, shift1.x(), shift1.y())};
  std::vector<Track> tracks = {{{{0, at_frame_time, shift0}, {1, at_frame_time, shift1}}}};
  RefineObservationsOptions o;
  RefineKeyframeObservations(o, gray, camera, map, &tracks);
  // Keyframe 1 is the reference; keyframe 0's place at the frame's time was right and stays.
  EXPECT_NEAR(tracks[0].obs[0].px.x(), at_frame_time.x(), 0.05);
  EXPECT_NEAR(tracks[0].obs[0].px.y(), at_frame_time.y(), 0.05);
  EXPECT_EQ(tracks[0].obs[0].picture_offset_px, shift0);
}

}  // namespace
}  // namespace stemmap::track
