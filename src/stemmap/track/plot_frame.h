#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <nlohmann/json.hpp>
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

struct GroundFitOptions {
  // Points below the camera circle between these distances from the axis (m): nearer, the
  // outward-facing camera sees no ground; farther, the points are too few and rough.
  double min_range_m = 2.0;
  double max_range_m = 12.0;
  // The floor of each cell of this size (m) votes once, so a shrub's many leaves count no more
  // than the patch of ground beside it.
  double cell_m = 0.5;
  double inlier_m = 0.05;      // a point or cell floor this close to the plane supports it (m)
  double max_tilt_deg = 20.0;  // steeper planes are not the ground
  int min_cells = 12;          // fewer measured cells: no ground found
  uint64_t seed = 7;           // of the plane's random samples
  void Check() const;
};
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(GroundFitOptions, min_range_m, max_range_m, cell_m,
                                                inlier_m, max_tilt_deg, min_cells, seed)

// The ground under the sparse points (axis frame: the camera circle is z = 0), as a plane. The
// ground is the floor of what the camera sees: shrubs, sapling crowns, litter and dead wood stand
// on it, so over much of a natural plot the points show their leaves and only gaps show the
// ground. Each cell's floor (a low percentile of its points) votes; of the planes through three
// floors, the one most floors lie on wins, less three times those lying clearly below it (the
// ground has nothing under it). The plane is then refitted to the floors it fits, weighting those
// above it down, and to the points near it. `found` is false when no plane has enough support.
GroundFit FitGround(const GroundFitOptions& options,
                    const std::vector<Eigen::Vector3d>& points_axis);

// The plot frame from the axis frame: origin where the axis meets the ground, z along `up_axis`
// (a unit vector in the axis frame), x along the horizontal viewing direction of
// `first_cam_forward_axis` (the first camera's optical axis in the axis frame).
Rigid3d PlotFromAxis(const Eigen::Vector3d& up_axis, double ground_height_at_axis_m,
                     const Eigen::Vector3d& first_cam_forward_axis);

}  // namespace stemmap::track
