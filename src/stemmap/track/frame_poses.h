#pragma once

#include <nlohmann/json.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/track/bundle_adjustment.h"
#include "stemmap/track/frontend.h"

namespace stemmap::track {

// Poses of the tracked frames between keyframes. The phone wobbles on the arm at 1-3 Hz while
// keyframes come every ~0.25 s, so interpolating keyframes misses most of the wobble; each such
// frame is instead resected against the adjusted points, with the same circle and mount priors
// as the bundle adjustment (the points, the mount and the focal length stay fixed).
struct FramePoseOptions {
  bool enabled = true;
  int min_points = 15;          // fewer inliers than this: keep the interpolated pose
  double inlier_px = 3.0;       // residual below which an observation counts as an inlier
  double max_change_deg = 3.0;  // a larger jump from the interpolated pose is not trusted
  int threads = 2;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(FramePoseOptions, enabled, min_points, inlier_px,
                                                max_change_deg, threads)

struct FramePoseSummary {
  int refined = 0, interpolated = 0;
  double mean_change_deg = 0.0;  // mean rotation from the interpolated to the refined pose
  double mean_rms_px = 0.0;      // of the inliers, over the refined frames
};

// `keyframes_axis` are world_from_cam in the axis frame (the map's frame), one per keyframe of
// `map`, stamped with the keyframe times. Returns one pose per entry of `between`, same frame.
// Where the map has a focal length per keyframe (focus breathing), each frame is resected at the
// one interpolated in time between the keyframes either side.
std::vector<StampedPose> RefineFramePoses(const FramePoseOptions& options,
                                          const BundleOptions& bundle,
                                          const std::vector<FrameObservations>& between,
                                          const std::vector<StampedPose>& keyframes_axis,
                                          const SparseMap& map, const PinholeCamera& camera,
                                          FramePoseSummary* summary);

// Pose at each time in `t_s` (sorted), interpolated between the stamped poses `poses` (sorted):
// slerp of the rotation, linear in the centre, held constant beyond the ends.
std::vector<StampedPose> InterpolatePoses(const std::vector<double>& t_s,
                                          const std::vector<StampedPose>& poses);

}  // namespace stemmap::track
