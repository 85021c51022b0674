#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/track/bundle_adjustment.h"
#include "stemmap/track/frontend.h"

namespace stemmap::track {

// KLT follows a point from frame to frame, each step matched against the last: its small errors
// add up along the track (a few hundredths of a pixel a frame), and over a turn they bend the
// keyframe headings and the camera's sideways place by millimetres, which a triangulation over
// the arm's one-metre baseline turns into centimetres at 10 m. Here every keyframe observation of
// a track is matched again against one reference view of it (its middle keyframe), its patch
// warped by the plane through the adjusted point facing that view: errors no longer add up.
struct RefineObservationsOptions {
  // Square patch side (working px): small, as the front end's KLT refinement, so that little of
  // what lies behind a trunk's edge (which moves against it) enters the patch.
  int window_px = 7;
  int max_iterations = 12;    // Gauss-Newton steps per observation
  double max_shift_px = 1.5;  // from the KLT place; further is not the same point
  double min_ncc = 0.9;       // patch agreement the new place must reach
  double min_gradient = 4.0;  // mean gradient (grey levels a px) of the reference patch
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RefineObservationsOptions, window_px,
                                                max_iterations, max_shift_px, min_ncc, min_gradient)

struct RefineObservationsSummary {
  int observations = 0;  // considered (valid, on a valid point, not a reference)
  int moved = 0;         // replaced by the matched place
  double mean_shift_px = 0.0;
  std::string BriefReport() const;
};

// 2x2 map from pixel offsets around point `x_world` in keyframe `ref` to pixel offsets in
// keyframe `kf`, for the plane through the point facing the reference camera. False when the point
// is not in front of both cameras.
bool LocalPatchWarp(const SparseMap& map, const PinholeCamera& camera, int ref, int kf,
                    const Eigen::Vector3d& x_world, Eigen::Matrix2d* ref_to_kf);

// Aligns a patch of `image` around `*px` (warped by `a`: patch offsets d -> a d) with the patch of
// `reference` around `ref_px`, with gain and offset for exposure changes. Updates *px and *ncc;
// false when the patch leaves an image, the reference patch is flat or the fit fails.
bool AlignPatch(const RefineObservationsOptions& o, const cv::Mat& reference,
                const Eigen::Vector2d& ref_px, const cv::Mat& image, const Eigen::Matrix2d& a,
                Eigen::Vector2d* px, double* ncc);

// Refines the observations of every valid point of `map` in `tracks` against the point's middle
// keyframe; `gray` holds each keyframe's working-resolution luma (CV_8U).
RefineObservationsSummary RefineKeyframeObservations(const RefineObservationsOptions& o,
                                                     const std::vector<cv::Mat>& gray,
                                                     const PinholeCamera& camera,
                                                     const SparseMap& map,
                                                     std::vector<Track>* tracks);

// Frames between keyframes keep their KLT places: each takes the correction its track got at the
// keyframes before and after it, interpolated in frame index (the drift is smooth along a track).
// `before` and `after` are the tracks before and after RefineKeyframeObservations.
void CarryCorrectionsToFrames(const std::vector<Track>& before, const std::vector<Track>& after,
                              const std::vector<Keyframe>& keyframes,
                              std::vector<FrameObservations>* between);

}  // namespace stemmap::track
