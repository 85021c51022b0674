#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
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
  // Segments are grouped into trunks by where their rays meet: a horizontal grid of this cell
  // votes for every cell a segment's ray crosses (from min to max range of its camera); the
  // best-voted cell takes the segments whose rays pass within ray_tolerance_m, and so on while a
  // cell holds min_trunk_segments.
  double cell_m = 0.3;
  double ray_tolerance_m = 0.35;
  double min_range_m = 1.0, max_range_m = 40.0;
  int min_trunk_segments = 3;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(VerticalOptions, inlier_deg, max_from_axis_deg,
                                                min_segments, cell_m, ray_tolerance_m, min_range_m,
                                                max_range_m, min_trunk_segments)

struct VerticalEstimate {
  bool found = false;
  Eigen::Vector3d up_axis = Eigen::Vector3d::UnitZ();  // unit, in the axis frame
  int segments = 0, inliers = 0, trunks = 0;
  double tilt_deg = 0.0;  // angle between the rotation axis and the vertical
  double sd_deg = 0.0;    // standard error of the estimate
};

// Uses the keyframes' vertical segments and the adjusted cameras in `map`. Trunks lean
// independently, so each trunk gets the same weight: a near trunk, seen large and with furrows in
// every view, must not outvote the many far ones (their mean lean is what the estimate cannot
// tell from the vertical).
VerticalEstimate EstimateVertical(const VerticalOptions& o, const std::vector<Keyframe>& keyframes,
                                  const SparseMap& map, const PinholeCamera& camera);

// Groups horizontal rays (origin, unit direction; axis frame) that meet at one trunk, as
// EstimateVertical does; `views` says which view (keyframe) each ray comes from, and a place
// needs rays from min_trunk_segments views to be a trunk. Returns one group index per ray (rays
// in no group get their own).
std::vector<int> GroupRaysByTrunk(const VerticalOptions& o,
                                  const std::vector<Eigen::Vector2d>& origins,
                                  const std::vector<Eigen::Vector2d>& directions,
                                  const std::vector<int>& views);

}  // namespace stemmap::track
