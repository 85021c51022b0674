#include "stemmap/track/rotation.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "stemmap/core/rng.h"

namespace stemmap::track {
namespace {

Eigen::Matrix3d YawPitch(double yaw, double pitch) {
  // A left turn of the camera is a rotation of its bearings about +y (see YawOfRotation).
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

TEST(Rotation, KabschRecoversRotation) {
  const Eigen::Matrix3d r = YawPitch(0.3, -0.05);
  Rng rng(1);
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 20; ++i) {
    a.push_back(Eigen::Vector3d(rng.Uniform(-1, 1), rng.Uniform(-0.5, 0.5), 1).normalized());
    b.push_back(r * a.back());
  }
  EXPECT_LT((FitRotation(a, b) - r).norm(), 1e-9);
  EXPECT_NEAR(YawOfRotation(YawPitch(0.3, 0.0)), 0.3, 1e-12);
  EXPECT_NEAR(YawOfRotation(r), 0.3, 1e-3);  // pitch couples in only weakly
}

TEST(Rotation, RansacIgnoresOutliers) {
  const Eigen::Matrix3d r = YawPitch(-0.1, 0.02);
  Rng rng(2);
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 100; ++i) {
    a.push_back(Eigen::Vector3d(rng.Uniform(-1, 1), rng.Uniform(-0.5, 0.5), 1).normalized());
    if (i % 3 == 0) {  // a third of the matches are wrong
      b.push_back(Eigen::Vector3d(rng.Uniform(-1, 1), rng.Uniform(-0.5, 0.5), 1).normalized());
    } else {
      b.push_back(r * a.back());
    }
  }
  const RotationFit fit = FitRotationRansac(a, b, 0.002, 200, 7);
  EXPECT_LT((fit.b_from_a - r).norm(), 1e-6);
  EXPECT_NEAR(fit.inliers.size(), 66u, 2);
  // Seeded: the same answer every time.
  EXPECT_EQ(FitRotationRansac(a, b, 0.002, 200, 7).inliers, fit.inliers);
}

}  // namespace
}  // namespace stemmap::track
