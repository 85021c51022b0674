#pragma once

#include <Eigen/Core>
#include <vector>

#include "stemmap/core/pose.h"

namespace stemmap::track {

struct GroundFit {
  bool found = false;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, pointing up
  double height_at_axis_m = 0.0;  // ground height at the rotation axis, in the input frame
  int inliers = 0;
  double slope_deg = 0.0;
};

// A robust plane through the sparse points below the camera circle (the plane z = 0 of the axis
// frame) between `min_range_m` and `max_range_m` from the axis. Seeded RANSAC, then least
// squares on the inliers; `found` is false when no plane within 20° of level has enough support.
GroundFit FitGround(const std::vector<Eigen::Vector3d>& points_axis, double min_range_m,
                    double max_range_m, double inlier_m, uint64_t seed);

// The plot frame from the axis frame: origin where the axis meets the ground, z along `up_axis`
// (a unit vector in the axis frame), x along the horizontal viewing direction of
// `first_cam_forward_axis` (the first camera's optical axis in the axis frame).
Rigid3d PlotFromAxis(const Eigen::Vector3d& up_axis, double ground_height_at_axis_m,
                     const Eigen::Vector3d& first_cam_forward_axis);

}  // namespace stemmap::track
