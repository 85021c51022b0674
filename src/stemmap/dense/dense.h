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
  // What those pairs see beyond near_max_depth_m, up to this (0: not kept): a third of the
  // baseline makes it coarse, but keyframes 5° apart both see a stem that a nearer one leaves in
  // view for only a few degrees of turn, where pairs 14° apart do not. Used only to find stems
  // the cloud missed (DenseResult::short_baseline_points).
  double short_baseline_max_depth_m = 12.0;
  // Pairs worked on at once: SGBM keeps only part of a second core busy. The cloud is the same
  // for any number (each pair's points are gathered in pair order).
  int pair_threads = 2;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(DenseOptions, stereo, pair_turn_deg,
                                                reference_step_deg, near_pair_turn_deg,
                                                near_min_depth_m, near_max_depth_m,
                                                short_baseline_max_depth_m, pair_threads)

class TrunkMaskModel;

struct DenseInput {
  PinholeCamera camera;                  // at the working resolution
  std::vector<StampedPose> keyframes;    // plot frame
  std::vector<cv::Mat> images;           // BGR keyframe images (empty Mat: not decoded)
  TrunkMaskModel* mask_model = nullptr;  // optional: labels points on trunks (CloudPoint::trunk)
};

struct DenseResult {
  std::vector<CloudPoint> points;  // plot frame
  // The near pairs' points beyond near_max_depth_m (DenseOptions::short_baseline_max_depth_m).
  std::vector<CloudPoint> short_baseline_points;
  int pairs = 0;
  double depth_focal_px = 0.0;  // focal length of the depth images at the points' spacing
  nlohmann::json summary;
};

// Depth for keyframe pairs, fused into one cloud that keeps each point's ray. Writes
// OUT/cloud.ply and OUT/cloud_coarse.ply (the short-baseline points; cloud_io.h) and
// OUT/dense_summary.json (with depth_focal_px).
DenseResult RunDense(const DenseOptions& options, const DenseInput& input,
                     const std::filesystem::path& out_dir);

}  // namespace stemmap::dense
