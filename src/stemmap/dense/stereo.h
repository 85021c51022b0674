#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"

namespace stemmap::dense {

// Two keyframes a few degrees of turn apart form a sideways stereo pair (the arm moves the camera
// along its x axis), slightly divergent; rectified, semi-global matching gives depth.
struct StereoOptions {
  double scale = 0.5;         // matching resolution relative to the keyframe images
  int num_disparities = 128;  // at that resolution, multiple of 16
  int block_size = 5;
  int uniqueness_ratio = 12;
  int speckle_window = 80;
  int speckle_range = 2;
  double min_depth_m = 0.8;
  double max_depth_m = 14.0;
  int pixel_step = 2;  // keep every n-th pixel of the depth map
  // Points within this share of the image's height of the lowest row the pair matched in their
  // column are marked CloudPoint::at_view_bottom: the frame's bottom edge cut the view there.
  double view_bottom_share = 0.04;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(StereoOptions, scale, num_disparities, block_size,
                                                uniqueness_ratio, speckle_window, speckle_range,
                                                min_depth_m, max_depth_m, pixel_step,
                                                view_bottom_share)

// A fused point that remembers where it was seen from: the camera centre gives its ray, so free
// space between the camera and the point can veto a false stem.
struct CloudPoint {
  Eigen::Vector3f world;
  Eigen::Vector3f origin;  // camera centre it was measured from
  cv::Vec3b bgr;
  int keyframe = 0;
  int8_t trunk = -1;  // learned trunk mask: 1 on a stem, 0 not, -1 no mask
  // Seen at the bottom edge of its pair's view: what lies below it there went unseen (within
  // ~4 m of the tripod the camera sees no ground; the lowest bark it shows is no ground).
  bool at_view_bottom = false;
};

// Depth points of one pair, in the world frame of the poses. `cam` is the images' camera.
// Points deeper than o.max_depth_m, up to beyond_max_depth_m, go to `beyond` when given.
std::vector<CloudPoint> StereoPairPoints(const StereoOptions& o, const cv::Mat& bgr_a,
                                         const cv::Mat& bgr_b, const PinholeCamera& cam,
                                         const Rigid3d& world_from_a, const Rigid3d& world_from_b,
                                         int keyframe_a, double beyond_max_depth_m = 0.0,
                                         std::vector<CloudPoint>* beyond = nullptr);

}  // namespace stemmap::dense
