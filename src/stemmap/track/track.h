#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/enum_names.h"
#include "stemmap/core/pose.h"
#include "stemmap/track/bundle_adjustment.h"
#include "stemmap/track/frame_poses.h"
#include "stemmap/track/frontend.h"
#include "stemmap/track/loop_closure.h"
#include "stemmap/track/plot_frame.h"
#include "stemmap/track/refine_observations.h"
#include "stemmap/track/vertical.h"

namespace stemmap::track {

// Field of view assumed when neither --hfov nor --calibration is given: the main camera of
// current phones filming 16:9 video (measure yours with `stemmap calibrate` for best results).
inline constexpr double kDefaultPhoneHfovDeg = 68.0;

// The focal length in bundle adjustment (TrackOptions::focal); in files and on the command line:
// auto, fixed, refine.
enum class FocalMode { kAuto, kFixed, kRefine };
inline constexpr EnumNames<FocalMode, 3> kFocalModeNames = {
    {{FocalMode::kAuto, "auto"}, {FocalMode::kFixed, "fixed"}, {FocalMode::kRefine, "refine"}}};
inline std::string_view FocalModeName(FocalMode m) { return EnumName(kFocalModeNames, m); }
STEMMAP_ENUM_JSON(FocalMode, kFocalModeNames, "focal mode")

// Where the plot frame's "up" comes from (TrackOptions::vertical_from); in files and on the
// command line: trunks, axis.
enum class VerticalSource { kTrunks, kAxis };
inline constexpr EnumNames<VerticalSource, 2> kVerticalSourceNames = {
    {{VerticalSource::kTrunks, "trunks"}, {VerticalSource::kAxis, "axis"}}};
inline std::string_view VerticalSourceName(VerticalSource s) {
  return EnumName(kVerticalSourceNames, s);
}
STEMMAP_ENUM_JSON(VerticalSource, kVerticalSourceNames, "vertical source")

struct TrackOptions {
  double arm_radius_m = 1.0;
  double hfov_deg = kDefaultPhoneHfovDeg;  // used when `calibration` is empty
  std::filesystem::path calibration;       // OpenCV YAML from `stemmap calibrate`
  // Refine the focal length in bundle adjustment, from the calibration's (or --hfov's): the
  // closed loop makes it observable. A far stem's range rests on the small excess of its apparent
  // turn over the camera's, so a focal length 0.7 % off (a phone's autofocus breathing, a
  // calibration at another focus) puts stems 10 m out 6 % too far; refined, it does not. kAuto
  // and kRefine refine it, kFixed keeps the calibration's (better where the focus stays locked
  // as it was for the calibration and the turn pins the focal length down poorly: a strongly
  // distorting wide lens, docs/benchmarks.md "Real phones").
  FocalMode focal = FocalMode::kAuto;
  // Arm height above the ground at the tripod, measured with a tape (m). 0: estimate it from the
  // ground seen around the plot, which misses any bump right under the tripod (the camera faces
  // outward and sees the ground only from ~4 m out).
  double camera_height_m = 0.0;
  // The plot frame's "up". kTrunks: the mean direction of the trunks' edges (EstimateVertical),
  // whatever the tripod's tilt; but trees lean, and on a plot whose trees lean one way more than
  // another it is 0.2-0.6 degrees off, which puts the ground at stems 10 m out 3-10 cm off.
  // kAxis: the arm's rotation axis, for a tripod levelled with its bubble before the turn (the
  // axis is found to about 0.02 degrees; the bubble's own accuracy, about 0.1 degrees, adds).
  VerticalSource vertical_from = VerticalSource::kTrunks;
  double min_turn_deg = 355.0;  // less than this is not a full turn
  double max_dark_share = 0.5;  // more dark frames than this: too dark
  // Where damaged or missing frames break the tracks, a gap up to this long (s) is bridged at the
  // turn rate of the keyframes either side; the loop closure then settles the heading.
  double max_bridged_gap_s = 3.0;
  int bundle_rounds = 3;
  // Focus breathing: after the rounds, one more refines a focal length per keyframe. Where at
  // least `breathing_min_keyframes` of them stray from their median by more than
  // `breathing_min_pct` (%, FocalScaleStrayPct), it is kept and the keyframes' pictures are
  // redrawn at the shared focal length; otherwise the round is undone. With a fixed focus no
  // keyframe strays by more than about 0.13 % at 960x540 (0.23 % on a short 480x270 clip); an
  // autofocus pulled to a near trunk moves it by up to about 1 % for as long as the trunk fills
  // the middle of the view.
  double breathing_min_pct = 0.5;
  int breathing_min_keyframes = 3;
  // Before the last round, the keyframe observations are matched again against one view of each
  // point (see refine_observations.h).
  bool refine_observations = true;
  RefineObservationsOptions refine;
  FrontendOptions frontend;
  LoopOptions loop;
  VerticalOptions vertical;
  BundleOptions bundle;
  FramePoseOptions frames;
  GroundFitOptions ground;  // the ground under the sparse points, without --camera-height
  // With a calibration, a turn of the arm looks like a turn times the apparent turn factor: 1,
  // plus up to apparent_turn_parallax (the arm carries the camera sideways, which turns the near
  // scene a little more). Beyond that band by more than this share, the video's focal length is
  // not the calibration's: a stabilising crop (in-camera stabilisation on), another lens, zoom or
  // video mode. The run warns, with the fix.
  double apparent_turn_parallax = 0.03;
  double calibration_focal_tolerance = 0.04;
  void Check() const;
};

// How many keyframes' focal lengths (over the shared one) stray from their median by more than
// breathing_min_pct: tracking keeps them where that is at least breathing_min_keyframes.
int BreathingKeyframes(const TrackOptions& options,
                       const std::vector<double>& keyframe_focal_scale);

// The warning for a calibrated run whose apparent turn per turn of the arm (`apparent_turn_factor`)
// says that the video's focal length is not the calibration's; empty when it agrees.
std::string CalibrationFocalWarning(const TrackOptions& options, double apparent_turn_factor);
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(TrackOptions, arm_radius_m, hfov_deg, calibration,
                                                focal, camera_height_m, vertical_from, min_turn_deg,
                                                max_dark_share, max_bridged_gap_s, bundle_rounds,
                                                breathing_min_pct, breathing_min_keyframes,
                                                refine_observations, refine, frontend, loop,
                                                vertical, bundle, frames, ground,
                                                apparent_turn_parallax, calibration_focal_tolerance)

struct TrackResult {
  PinholeCamera camera;                  // working resolution
  std::vector<StampedPose> frames;       // every decoded frame, world_from_cam in the plot frame
  std::vector<StampedPose> keyframes;    // the adjusted keyframes, plot frame
  std::vector<cv::Mat> keyframe_images;  // BGR, working resolution, when the front end keeps them
  std::vector<cv::Mat> keyframe_gray_full;  // luma at the video's resolution, likewise
  // Where focus breathing was corrected: each keyframe's focal length over `camera`'s, with which
  // its pictures above were redrawn at `camera`'s (UndoFocalScale). Empty otherwise.
  std::vector<double> keyframe_focal_scale;
  std::vector<Eigen::Vector3d> points_plot;
  Rigid3d plot_from_axis;
  nlohmann::json summary;  // tracking quality, loop, scale, timings
  std::string BriefReport() const;
};

// `stemmap track`: camera trajectory with metric scale from the arm radius. Writes
// OUT/trajectory.tum, OUT/keyframes.tum, OUT/sparse.ply, OUT/summary.json ({"track": ...}) and
// OUT/track_options.json, staged and moved into OUT whole at the end (StagedRunFolder). Throws
// InputError for unusable output folders (before any work) and unreadable, too dark or too short
// videos, and ProcessingError when tracking cannot be recovered.
TrackResult RunTrack(const TrackOptions& options, const std::filesystem::path& video,
                     const std::filesystem::path& out_dir);

// The same work, written straight into `dir` (summary.json last, so a folder that has it holds a
// finished track): for a larger run that stages its own folder.
TrackResult TrackInto(const TrackOptions& options, const std::filesystem::path& video,
                      const std::filesystem::path& dir);

nlohmann::json ToJson(const TrackOptions& options);

}  // namespace stemmap::track
