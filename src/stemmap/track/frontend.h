#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/video/video_reader.h"

namespace stemmap::track {

// Feature tracking over the whole video: KLT tracks between tracked frames, recorded at keyframes
// chosen by rotation; ORB features at keyframes for loop closure.
struct FrontendOptions {
  int working_long_side_px = 960;  // tracking resolution
  double track_fps = 15.0;         // frames tracked per second; the rest are only decoded
  int max_features = 500;          // KLT points alive at once
  double min_feature_distance_px = 14.0;
  double feature_quality = 0.003;  // goodFeaturesToTrack quality level
  int lk_window_px = 21;           // finds the motion, however large, on a 3-level pyramid
  int lk_levels = 3;
  // ...then a small window places the point: a large one takes in a trunk's edge and the
  // background beside it, which move apart as the camera turns, and pulls the point along by a
  // few hundredths of a pixel a frame. Over a turn that bent the keyframe headings by 0.1-0.7°.
  int lk_refine_window_px = 7;
  int lk_refine_levels = 2;
  double lk_refine_max_shift_px = 1.0;  // further from the large window's place: not the same point
  double max_forward_backward_px = 0.8;  // KLT consistency check
  double keyframe_step_deg = 2.0;        // apparent rotation between keyframes
  int orb_features = 800;                // per keyframe, for loop closure
  bool keep_keyframe_images = false;     // keep each keyframe's BGR image for later stages
  double dark_mean_luma = 20.0;          // frames darker than this (0-255) count as dark
  // Vertical segments: shortest, as a share of height. Short ones count: far trunks, partly hidden
  // and low in contrast, give only pieces, and it takes many trunks to average out their leans.
  double segment_min_length = 0.04;
  double segment_max_tilt_deg = 15.0;  // and furthest from the image vertical
  // A rolling shutter reads the rows top to bottom over this time (ms; 0: a global shutter): a
  // point in row y is seen readout (y / (rows - 1) - 1/2) after the frame's time, its middle
  // row's. Each observation is moved back to that time along its own image velocity (from the
  // frame before), and each trunk segment's ends along the frame's median velocity, so a turning
  // camera's slant leaves neither the poses nor the vertical.
  double readout_ms = 0.0;
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    FrontendOptions, working_long_side_px, track_fps, max_features, min_feature_distance_px,
    feature_quality, lk_window_px, lk_levels, lk_refine_window_px, lk_refine_levels,
    lk_refine_max_shift_px, max_forward_backward_px, keyframe_step_deg, orb_features,
    keep_keyframe_images, dark_mean_luma, segment_min_length, segment_max_tilt_deg, readout_ms)

struct Observation {
  int keyframe = 0;
  Eigen::Vector2d px;  // working-resolution pixel (at the frame's time: readout_ms)
  // Where the picture shows the point, less `px`: its row's rolling-shutter shift (zero for a
  // global shutter). Patches are matched where the picture shows them.
  Eigen::Vector2d picture_offset_px = Eigen::Vector2d::Zero();
};

// Where a point seen at `px` (its row's time) with image velocity `px_per_s` was at the frame's
// time, its middle row's, for rows read over `readout_s` in an image `rows` high.
Eigen::Vector2d AtFrameTime(const Eigen::Vector2d& px, const Eigen::Vector2d& px_per_s,
                            double readout_s, int rows);

struct Track {
  std::vector<Observation> obs;  // ordered by keyframe
};

struct Keyframe {
  int frame = 0;  // index into FrontendResult::frame_t_s
  double t_s = 0.0;
  std::vector<cv::KeyPoint> orb_keypoints;
  cv::Mat orb_descriptors;
  // Long near-vertical line segments (x0, y0, x1, y1, working px): trunk edges, for "up".
  std::vector<cv::Vec4f> vertical_segments;
  // The picture's median velocity when it was taken (working px/s): moves what is found in it
  // later (a loop's ORB matches) to the frame's time under a rolling shutter.
  Eigen::Vector2d picture_px_per_s = Eigen::Vector2d::Zero();
  cv::Mat gray;       // working resolution, always (observations are refined on it)
  cv::Mat bgr;        // working resolution, when FrontendOptions::keep_keyframe_images
  cv::Mat gray_full;  // full resolution, when kept and the reader returns it
};

// Where the tracked points lie in one tracked frame between keyframes: for refining its pose
// against the adjusted map, so the trajectory follows the arm's wobble between keyframes.
struct FrameObservations {
  int frame = 0;  // index into FrontendResult::frame_t_s
  double t_s = 0.0;
  std::vector<int> track;           // index into FrontendResult::tracks
  std::vector<Eigen::Vector2f> px;  // working-resolution pixel, one per track
};

struct FrontendResult {
  VideoInfo info;
  int corrupt_packets = 0;
  int tracked_frames = 0;
  int dark_frames = 0;
  cv::Size working_size;
  double readout_s = 0.0;         // the rolling shutter's readout (FrontendOptions::readout_ms)
  std::vector<double> frame_t_s;  // every decoded frame
  std::vector<Keyframe> keyframes;
  std::vector<Track> tracks;               // only tracks seen in two or more keyframes
  std::vector<FrameObservations> between;  // tracked frames that are not keyframes, in order
  double mean_tracked_points = 0.0;
  int reseeds_for_loss = 0;  // times the tracker lost most points and started over
  // How the picture moved: the median shift of the followed points between tracked frames,
  // summed over the video (working px). A turning arm moves it sideways; a still camera hardly at
  // all; a picture turned 90° moves it up or down.
  double sideways_motion_px = 0.0;
  double vertical_motion_px = 0.0;
  // Frames the decoder could only partly reconstruct (damaged data): not tracked; the times they
  // span, merged into intervals [start, end] (s), with the gaps where frames are missing.
  int damaged_frames = 0;
  std::vector<std::pair<double, double>> damaged_spans_s;
};

// Reads the remaining frames of `reader` (opened at the working resolution) and tracks features.
// `camera` is the working-resolution camera. Throws InputError when no frame can be decoded.
FrontendResult RunFrontend(const FrontendOptions& options, VideoReader& reader,
                           const PinholeCamera& camera);

}  // namespace stemmap::track
