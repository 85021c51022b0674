#pragma once

#include <Eigen/Core>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/track/frontend.h"

namespace stemmap::track {

// Kabsch: the rotation R minimising sum |b_i - R a_i|^2 over unit bearings.
Eigen::Matrix3d FitRotation(const std::vector<Eigen::Vector3d>& a,
                            const std::vector<Eigen::Vector3d>& b);

struct RotationFit {
  Eigen::Matrix3d b_from_a = Eigen::Matrix3d::Identity();
  std::vector<int> inliers;
};

// Rotation-only RANSAC on bearing pairs (2-point samples), refined on the inliers. `threshold_rad`
// is the largest angle between b and R a for an inlier. Seeded, so repeatable.
RotationFit FitRotationRansac(const std::vector<Eigen::Vector3d>& a,
                              const std::vector<Eigen::Vector3d>& b, double threshold_rad,
                              int iterations, uint64_t seed);

// Left turn (rad) of camera b relative to camera a about the camera's -y (up) axis, from the
// rotation that maps a's bearings to b's.
double YawOfRotation(const Eigen::Matrix3d& b_from_a);

// Arm-angle increments between consecutive keyframes, from the tracked points' image motion.
// The arm also moves the camera sideways, which adds parallax in the same direction as the turn,
// so the increment is taken from the points that moved least (the far ones): a low percentile.
// Entry k is the turn from keyframe k-1 to k (entry 0 is 0). A link with too few shared points
// is NaN.
std::vector<double> ApparentTurnIncrements(const FrontendResult& frontend,
                                           const PinholeCamera& camera, double percentile,
                                           int min_shared_points);

}  // namespace stemmap::track
