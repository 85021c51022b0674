#include "stemmap/dense/dense.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "stemmap/core/error.h"

namespace stemmap::dense {
namespace {

// A speckled value at (azimuth, height) on a wall: the same spot looks the same from anywhere.
uint8_t Speckle(double azimuth_rad, double z_m) {
  const auto cell = [](double v, double size) {
    return static_cast<int64_t>(std::floor(v / size));
  };
  uint64_t h = static_cast<uint64_t>(cell(azimuth_rad * 4.0, 0.02)) * 0x9E3779B97F4A7C15ull ^
               static_cast<uint64_t>(cell(z_m, 0.02)) * 0xC2B2AE3D27D4EB4Full;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return static_cast<uint8_t>(40 + h % 180);
}

// Keyframes every 2° of turn on a 1-m arm, looking outward at a speckled wall 4 m from the
// tripod, rendered by casting each pixel's ray.
DenseInput WallScene() {
  DenseInput in;
  in.camera = PinholeCamera::FromHfov(320, 180, 65.0);
  for (int k = 0; k < 14; ++k) {
    const double heading = 2.0 * k * M_PI / 180.0;
    const Eigen::Vector3d forward(std::cos(heading), std::sin(heading), 0.0);
    const Eigen::Vector3d down(0, 0, -1), right = down.cross(forward);
    Eigen::Matrix3d world_from_cam_rotation;
    world_from_cam_rotation << right, down, forward;
    StampedPose pose;
    pose.t_s = k;
    pose.world_from_cam.rotation = Eigen::Quaterniond(world_from_cam_rotation);
    pose.world_from_cam.translation = Eigen::Vector3d(forward.x(), forward.y(), 1.3);
    cv::Mat bgr(in.camera.height, in.camera.width, CV_8UC3);
    const Eigen::Vector3d c = pose.world_from_cam.translation;
    for (int y = 0; y < bgr.rows; ++y) {
      for (int x = 0; x < bgr.cols; ++x) {
        const Eigen::Vector3d ray = world_from_cam_rotation * in.camera.CamRayFromImage({x, y});
        // |c + t ray|_xy = 4: the far root of a t^2 + 2 b t + q = 0.
        const double a = ray.head<2>().squaredNorm(), b = c.head<2>().dot(ray.head<2>());
        const double q = c.head<2>().squaredNorm() - 16.0;
        const double t = (-b + std::sqrt(b * b - a * q)) / a;
        const Eigen::Vector3d p = c + t * ray;
        const uint8_t v = Speckle(std::atan2(p.y(), p.x()), p.z());
        bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(v, v, v);
      }
    }
    in.keyframes.push_back(pose);
    in.images.push_back(bgr);
  }
  return in;
}

// The pairs are worked on in parallel, and the cloud is the same point for point with one
// thread or several; its points lie on the wall.
TEST(Dense, TheCloudDoesNotDependOnThePairThreads) {
  const DenseInput in = WallScene();
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("stemmap_dense_" + std::to_string(::getpid()));
  DenseOptions o;
  o.near_pair_turn_deg = 0;
  o.pair_threads = 1;
  const DenseResult one = RunDense(o, in, dir / "one");
  o.pair_threads = 3;
  const DenseResult three = RunDense(o, in, dir / "three");
  ASSERT_GE(one.pairs, 2);
  EXPECT_EQ(one.pairs, three.pairs);
  ASSERT_GT(one.points.size(), 1000u);
  ASSERT_EQ(one.points.size(), three.points.size());
  int on_wall = 0;
  for (size_t i = 0; i < one.points.size(); ++i) {
    ASSERT_EQ(one.points[i].world, three.points[i].world) << i;
    ASSERT_EQ(one.points[i].keyframe, three.points[i].keyframe) << i;
    on_wall += std::abs(one.points[i].world.head<2>().norm() - 4.0f) < 0.1f;
  }
  EXPECT_GT(on_wall, 0.9 * one.points.size());
  o.pair_threads = 0;
  EXPECT_THROW(o.Check(), InputError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace stemmap::dense
