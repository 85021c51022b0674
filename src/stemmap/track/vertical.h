#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/track/bundle_adjustment.h"
#include "stemmap/track/frontend.h"

namespace stemmap::track {

// "Up" from the scene: trunks stand near vertical (each leans a little, in its own direction), so
// the direction orthogonal to the planes through the camera and each trunk edge is the vertical.
// The tripod's axis is not: a stand tilted by a degree tilts the whole circle.
struct VerticalOptions {
  double inlier_deg = 2.0;         // robust weight scale of a segment's plane residual
  double max_from_axis_deg = 6.0;  // the stand is never tilted further than this
  int min_segments = 30;
  double cell_m = 0.6;       // segments located within one cell are one trunk
  double far_bin_deg = 1.5;  // segments without a located point: one trunk per azimuth bin
  double match_px = 4.0;     // track observations this close to a segment locate it
  void Check() const;
};

struct VerticalEstimate {
  bool found = false;
  Eigen::Vector3d up_axis = Eigen::Vector3d::UnitZ();  // unit, in the axis frame
  int segments = 0, inliers = 0, trunks = 0;
  double tilt_deg = 0.0;  // angle between the rotation axis and the vertical
  double sd_deg = 0.0;    // standard error of the estimate
};

// Uses the keyframes' vertical segments and the adjusted cameras and points in `map`. Trunks lean
// independently, so each trunk (segments grouped by where they stand) gets the same weight: a near
// trunk, seen large and with furrows, must not outvote the many far ones.
VerticalEstimate EstimateVertical(const VerticalOptions& o, const std::vector<Keyframe>& keyframes,
                                  const std::vector<Track>& tracks, const SparseMap& map,
                                  const PinholeCamera& camera);

}  // namespace stemmap::track
