#include "stemmap/core/pose.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap {
namespace {

TEST(Pose, InverseAndComposition) {
  Rigid3d a{Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
            Eigen::Vector3d(1, -2, 0.5)};
  const Eigen::Vector3d p(0.2, 4, -1);
  EXPECT_TRUE(((a.Inverse() * a) * p).isApprox(p, 1e-12));
  EXPECT_TRUE((a * (a.Inverse() * p)).isApprox(p, 1e-12));
}

TEST(Pose, TumRoundTripAndErrors) {
  const auto dir = std::filesystem::temp_directory_path();
  const auto path = dir / "stemmap_pose_test.tum";
  std::vector<StampedPose> poses;
  for (int i = 0; i < 5; ++i) {
    poses.push_back({i / 30.0,
                     {Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitZ())),
                      Eigen::Vector3d(i / 3.0, 0.5 * i + 0.1, 1.3)}});
  }
  WriteTumTrajectory(path, poses);
  const auto back = ReadTumTrajectory(path);
  ASSERT_EQ(back.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_NEAR(back[i].t_s, poses[i].t_s, 1e-6);
    // Bit for bit: a stage rerun on a saved track must see the poses the first run used.
    EXPECT_EQ(back[i].world_from_cam.translation, poses[i].world_from_cam.translation);
    EXPECT_EQ(back[i].world_from_cam.rotation.coeffs(), poses[i].world_from_cam.rotation.coeffs());
  }
  WriteFileAtomic(path, "0 1 2 3 0 0\n");
  EXPECT_THROW(ReadTumTrajectory(path), InputError);
}

}  // namespace
}  // namespace stemmap
