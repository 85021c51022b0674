#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/dense/stereo.h"

namespace stemmap::dense {

struct DenseOptions {
  StereoOptions stereo;
  double pair_turn_deg = 14.0;      // turn between the two keyframes of a pair (baseline ~0.24 m)
  double reference_step_deg = 4.0;  // one reference keyframe every this much turn
  // Near stems (a metre or two from the camera) look too different from keyframes 14° apart to
  // match; pairs this far apart (0: none) add depth between near_min_depth_m and near_max_depth_m.
  double near_pair_turn_deg = 5.0;
  double near_min_depth_m = 0.5;
  double near_max_depth_m = 2.5;
  void Check() const;
};

class TrunkMaskModel;

struct DenseInput {
  PinholeCamera camera;                  // at the working resolution
  std::vector<StampedPose> keyframes;    // plot frame
  std::vector<cv::Mat> images;           // BGR keyframe images (empty Mat: not decoded)
  TrunkMaskModel* mask_model = nullptr;  // optional: labels points on trunks (CloudPoint::trunk)
};

struct DenseResult {
  std::vector<CloudPoint> points;  // plot frame
  int pairs = 0;
  double depth_focal_px = 0.0;  // focal length of the depth images at the points' spacing
  nlohmann::json summary;
};

// Depth for keyframe pairs, fused into one cloud that keeps each point's ray. Writes
// OUT/cloud.ply (binary: x y z, red green blue, ray origin ox oy oz) and OUT/dense_summary.json.
DenseResult RunDense(const DenseOptions& options, const DenseInput& input,
                     const std::filesystem::path& out_dir);

// Binary little-endian PLY of the cloud, written atomically.
void WriteCloudPly(const std::filesystem::path& path, const std::vector<CloudPoint>& points);

}  // namespace stemmap::dense
