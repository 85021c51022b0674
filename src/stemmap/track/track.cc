#include "stemmap/track/track.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "stemmap/calib/calibrate.h"
#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/run_folder.h"
#include "stemmap/core/units.h"
#include "stemmap/track/frame_poses.h"
#include "stemmap/track/keyframe_zoom.h"
#include "stemmap/track/plot_frame.h"
#include "stemmap/track/rotation.h"
#include "stemmap/track/track_io.h"
#include "stemmap/track/video_checks.h"

namespace stemmap::track {

namespace {

double WrapPi(double a) { return std::remainder(a, 2.0 * M_PI); }

class Stopwatch {
 public:
  double Lap() {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// Loop error (deg): how far the trajectory's relative yaw at each revisit is from the measured one.
double MeanLoopErrorDeg(const LoopResult& loop, const SparseMap& map) {
  if (loop.pairs.empty()) return 0.0;
  double sum = 0.0;
  for (const LoopPair& p : loop.pairs) {
    const Eigen::Matrix3d late_from_early =
        (map.cam_from_world[p.late] * map.cam_from_world[p.early].conjugate()).toRotationMatrix();
    sum += std::abs(WrapPi(YawOfRotation(late_from_early) - p.yaw_rad));
  }
  return sum / loop.pairs.size() / kDeg;
}

double MeanOdometryLoopErrorDeg(const LoopResult& loop, const std::vector<double>& turn) {
  if (loop.pairs.empty()) return 0.0;
  const double sign = turn.back() >= 0 ? 1.0 : -1.0;
  double sum = 0.0;
  for (const LoopPair& p : loop.pairs) {
    sum += std::abs(turn[p.late] - turn[p.early] - (sign * 2.0 * M_PI + p.yaw_rad));
  }
  return sum / loop.pairs.size() / kDeg;
}

PinholeCamera WorkingCamera(const TrackOptions& o, const VideoInfo& info) {
  const int long_side = std::max(info.width, info.height);
  double s = 1.0;
  const int max_side = o.frontend.working_long_side_px;
  if (max_side > 0 && long_side > max_side) s = static_cast<double>(max_side) / long_side;
  const int w = std::max(2, static_cast<int>(std::lround(info.width * s)));
  const int h = std::max(2, static_cast<int>(std::lround(info.height * s)));
  if (!o.calibration.empty()) return calib::ReadCalibration(o.calibration, w, h);
  return PinholeCamera::FromHfov(w, h, o.hfov_deg);
}

// One more round in which each keyframe has its own focal length (focus breathing). A focal
// length that breathes while one is shared is taken up by the camera centres, moved in and out
// by centimetres (BundleAdjustment.AFocalLengthPerKeyframeFollowsABreathingFocus), so the
// breathing shows only once each keyframe may have its own.
BundleSummary AdjustForBreathing(const BundleOptions& bo, const std::vector<Track>& tracks,
                                 const PinholeCamera& camera, SparseMap* map) {
  map->keyframe_focal_scale.assign(map->centre_world.size(), 1.0);
  TriangulateTracks(bo, tracks, camera, map);
  return RunBundleAdjustment(bo, tracks, camera, map);
}

// The keyframes' pictures and trunk edges as `camera` (working size) would have shown them, from
// pictures taken at `focal_scale` times its focal length.
void RedrawAtSharedFocal(const PinholeCamera& camera, const std::vector<double>& focal_scale,
                         std::vector<Keyframe>* keyframes) {
  for (size_t k = 0; k < keyframes->size(); ++k) {
    Keyframe& kf = (*keyframes)[k];
    const double s = focal_scale[k];
    kf.gray = UndoFocalScale(kf.gray, camera, s);
    kf.bgr = UndoFocalScale(kf.bgr, camera, s);
    if (!kf.gray_full.empty()) {
      kf.gray_full = UndoFocalScale(
          kf.gray_full, camera.Scaled(static_cast<double>(kf.gray_full.cols) / camera.width), s);
    }
    for (cv::Vec4f& seg : kf.vertical_segments) {
      for (int i = 0; i < 4; i += 2) {
        seg[i] = static_cast<float>(camera.cx + (seg[i] - camera.cx) / s);
        seg[i + 1] = static_cast<float>(camera.cy + (seg[i + 1] - camera.cy) / s);
      }
    }
  }
}

}  // namespace

void TrackOptions::Check() const {
  ground.Check();
  if (!(max_bridged_gap_s >= 0)) throw InputError("the longest bridged gap must not be negative");
  if (calibration.empty() && !(hfov_deg >= 20.0 && hfov_deg <= 150.0)) {
    throw InputError(fmt::format("--hfov {}° is outside 20-150°", hfov_deg));
  }
  if (camera_height_m < 0 || camera_height_m > 3.0) {
    throw InputError(fmt::format("--camera-height {} m is outside 0-3 m", camera_height_m));
  }
  if (bundle_rounds < 1) throw InputError("at least one bundle adjustment round is needed");
  if (!(breathing_min_pct >= 0) || breathing_min_keyframes < 1) {
    throw InputError(fmt::format(
        "focus breathing needs a focal stray of at least 0 % ({} %) in at least 1 keyframe ({})",
        breathing_min_pct, breathing_min_keyframes));
  }
  if (!(apparent_turn_parallax >= 0 && apparent_turn_parallax < 0.2) ||
      !(calibration_focal_tolerance > 0 && calibration_focal_tolerance < 0.5)) {
    throw InputError(
        "the apparent turn's parallax share must lie in [0, 0.2) and the calibration's focal "
        "tolerance in (0, 0.5)");
  }
  frontend.Check();
  loop.Check();
  frames.Check();
  refine.Check();
  BundleOptions b = bundle;
  b.arm_radius_m = arm_radius_m;
  b.Check();
}

int BreathingKeyframes(const TrackOptions& o, const std::vector<double>& keyframe_focal_scale) {
  const std::vector<double> stray_pct = FocalScaleStrayPct(keyframe_focal_scale);
  return static_cast<int>(std::count_if(stray_pct.begin(), stray_pct.end(),
                                        [&](double p) { return p > o.breathing_min_pct; }));
}

std::string CalibrationFocalWarning(const TrackOptions& o, double apparent_turn_factor) {
  if (o.calibration.empty() || !(apparent_turn_factor > 0)) return {};
  const double low = 1.0 - o.calibration_focal_tolerance;
  const double high = 1.0 + o.apparent_turn_parallax + o.calibration_focal_tolerance;
  if (apparent_turn_factor >= low && apparent_turn_factor <= high) return {};
  // The apparent turn scales as the calibration's focal length over the video's.
  const double longer_pct =
      100.0 * (apparent_turn_factor / (1.0 + 0.5 * o.apparent_turn_parallax) - 1.0);
  return fmt::format(
      "the video's focal length looks {:.0f} % {} than the calibration's (a turn of the arm "
      "looked like {:.0f}°): in-camera stabilisation crops the picture (turn it off), or the "
      "video was recorded with another lens, zoom or video mode than the calibration; positions "
      "and diameters will be off by about as much",
      std::abs(longer_pct), longer_pct > 0 ? "longer" : "shorter", 360.0 * apparent_turn_factor);
}

std::string TrackResult::BriefReport() const {
  return fmt::format(
      "{} keyframes over {:.1f}°, loop error {:.2f}° -> {:.3f}° ({} revisits), rms {:.2f} px, "
      "camera {:.3f} m above ground",
      keyframes.size(), summary.value("turn_deg", 0.0), summary.value("loop_error_before_deg", 0.0),
      summary.value("loop_error_after_deg", 0.0), summary.value("loop_pairs", 0),
      summary.value("reprojection_rms_px", 0.0), summary.value("camera_height_m", 0.0));
}

TrackResult RunTrack(const TrackOptions& o, const std::filesystem::path& video,
                     const std::filesystem::path& out_dir) {
  o.Check();
  StagedRunFolder folder(out_dir);
  TrackResult r = TrackInto(o, video, folder.staging());
  folder.Commit({{"command", "track"}, {"video", std::filesystem::absolute(video).string()}});
  return r;
}

TrackResult TrackInto(const TrackOptions& o, const std::filesystem::path& video,
                      const std::filesystem::path& out_dir) {
  o.Check();
  Stopwatch clock;
  nlohmann::json timing;
  TrackResult r;
  VideoReaderOptions vro;
  vro.max_long_side_px = o.frontend.working_long_side_px;
  vro.full_gray = o.frontend.keep_keyframe_images;
  vro.prefetch_frames = 8;  // decoding overlaps tracking
  vro.wanted = [track_fps = o.frontend.track_fps](const VideoInfo& info, int64_t index, double) {
    return index % FrameStride(info.fps, track_fps) == 0;
  };
  VideoReader reader(video, vro);
  CheckFrameSize(reader.info());
  r.camera = WorkingCamera(o, reader.info());
  spdlog::info("track: {}x{} {:.2f} fps {}, working {}x{}, hfov {:.1f}°", reader.info().width,
               reader.info().height, reader.info().fps, reader.info().codec, r.camera.width,
               r.camera.height, r.camera.HfovDeg());
  FrontendResult f = RunFrontend(o.frontend, reader, r.camera);
  timing["decode_and_klt_s"] = clock.Lap();
  const std::string damage = DamageNote(f);
  if (f.dark_frames > o.max_dark_share * f.tracked_frames) {
    throw InputError(fmt::format(
        "the video is too dark to track ({} of {} frames dark): record in daylight, with the "
        "exposure unlocked or set brighter{}",
        f.dark_frames, f.tracked_frames, damage));
  }
  constexpr int kMinFramesToJudgeMotion = 20;
  if (f.tracked_frames >= kMinFramesToJudgeMotion) {
    const std::string problem = MotionProblem(f, r.camera);
    if (!problem.empty()) throw InputError(problem + damage);
  }
  if (f.keyframes.size() < 3) {
    throw InputError(fmt::format(
        "the video is too short to track ({} frames, {} keyframes; one turn of the arm takes "
        "40-50 s){}",
        f.frame_t_s.size(), f.keyframes.size(), damage));
  }
  if (!damage.empty()) spdlog::warn("track: {}", damage.substr(2));
  std::vector<double> inc = ApparentTurnIncrements(f, r.camera, 0.1, 15);
  const std::vector<std::pair<double, double>> bridged =
      BridgeDamagedGaps(f, o.max_bridged_gap_s, &inc);
  for (const auto& [from_s, to_s] : bridged) {
    spdlog::warn("track: tracks broken by damaged frames bridged from {:.1f} to {:.1f} s", from_s,
                 to_s);
  }
  std::vector<double> turn(inc.size(), 0.0);
  for (size_t k = 1; k < inc.size(); ++k) {
    if (std::isnan(inc[k])) {
      throw ProcessingError(fmt::format(
          "tracking lost at t={:.1f} s: too few points followed between keyframes (covered "
          "lens, blur or a scene without texture?){}",
          f.keyframes[k].t_s, damage));
    }
    turn[k] = turn[k - 1] + inc[k];
  }
  LoopResult loop = FindLoops(o.loop, f, r.camera, turn);
  timing["loop_detection_s"] = clock.Lap();
  if (loop.pairs.empty()) {
    throw InputError(fmt::format(
        "the video does not return to its start: no revisit found after {:.0f}° of apparent "
        "turn (one full turn of the arm is needed){}",
        std::abs(turn.back()) / kDeg, damage));
  }
  const double to_true = 2.0 * M_PI / loop.apparent_per_turn_rad;
  const std::string focal_warning =
      CalibrationFocalWarning(o, loop.apparent_per_turn_rad / (2.0 * M_PI));
  if (!focal_warning.empty()) spdlog::warn("{}", focal_warning);
  std::vector<double> phi(turn.size());
  for (size_t k = 0; k < turn.size(); ++k) phi[k] = turn[k] * to_true;
  const double turn_deg = std::abs(phi.back()) / kDeg;
  if (turn_deg < o.min_turn_deg) {
    throw InputError(
        fmt::format("the video covers {:.0f}° of turn; one full turn (360°) is needed: keep "
                    "recording until the first view comes round again{}",
                    turn_deg, damage));
  }
  MergeLoopTracks(o.loop, f, loop);

  SparseMap map;
  BundleOptions bo = o.bundle;
  bo.arm_radius_m = o.arm_radius_m;
  bo.refine_focal = o.focal != FocalMode::kFixed;
  PlaceOnCircle(phi, o.arm_radius_m, &map);
  nlohmann::json rounds = nlohmann::json::array();
  BundleSummary bs;
  std::string refine_report;
  double refine_s = 0.0;
  for (int round = 0; round < o.bundle_rounds; ++round) {
    if (o.refine_observations && round > 0 && round + 1 == o.bundle_rounds) {
      Stopwatch refine_clock;
      std::vector<cv::Mat> gray;
      for (const Keyframe& kf : f.keyframes) gray.push_back(kf.gray);
      const std::vector<Track> klt_tracks = f.tracks;
      const RefineObservationsSummary rs =
          RefineKeyframeObservations(o.refine, gray, r.camera, map, &f.tracks);
      CarryCorrectionsToFrames(klt_tracks, f.tracks, f.keyframes, &f.between);
      spdlog::info("track: observations refined: {}", rs.BriefReport());
      refine_report = rs.BriefReport();
      refine_s = refine_clock.Lap();
    }
    const int made = TriangulateTracks(bo, f.tracks, r.camera, &map);
    BundleOptions round_options = bo;
    if (round + 1 < o.bundle_rounds) {
      round_options.function_tolerance = bo.early_round_function_tolerance;
    }
    if (round == 0) round_options.max_track_rms_px = 0.0;  // the poses are the guesses still
    bs = RunBundleAdjustment(round_options, f.tracks, r.camera, &map);
    spdlog::info("track: bundle adjustment {}/{}: {} (+{} points)", round + 1, o.bundle_rounds,
                 bs.BriefReport(), made);
    rounds.push_back(bs.BriefReport());
  }
  // Focus breathing: one more round with a focal length per keyframe, kept where they stray.
  SparseMap shared_focal_map = map;
  const BundleSummary breathing_bs = AdjustForBreathing(bo, f.tracks, r.camera, &map);
  const std::vector<double> stray_pct = FocalScaleStrayPct(map.keyframe_focal_scale);
  const double focal_max_stray_pct =
      stray_pct.empty() ? 0.0 : *std::max_element(stray_pct.begin(), stray_pct.end());
  const int breathing_keyframes = BreathingKeyframes(o, map.keyframe_focal_scale);
  if (breathing_keyframes >= o.breathing_min_keyframes) {
    bs = breathing_bs;
    spdlog::info(
        "track: the focal length breathes ({} keyframes {:.1f} % or more from the rest, up to "
        "{:.1f} %); per keyframe: {}",
        breathing_keyframes, o.breathing_min_pct, focal_max_stray_pct, bs.BriefReport());
    rounds.push_back(bs.BriefReport());
  } else {
    map = std::move(shared_focal_map);
  }
  timing["bundle_adjustment_s"] = clock.Lap() - refine_s;
  timing["refine_observations_s"] = refine_s;
  const double initial_hfov_deg = r.camera.HfovDeg();
  r.camera.fx *= map.focal_scale;
  r.camera.fy *= map.focal_scale;
  map.focal_scale = 1.0;
  if (!map.keyframe_focal_scale.empty()) {
    RedrawAtSharedFocal(r.camera, map.keyframe_focal_scale, &f.keyframes);
    r.keyframe_focal_scale = map.keyframe_focal_scale;
  }
  std::vector<StampedPose> keyframes_axis;
  for (size_t k = 0; k < map.centre_world.size(); ++k) {
    keyframes_axis.push_back(
        {f.keyframes[k].t_s, {map.cam_from_world[k].conjugate(), map.centre_world[k]}});
  }
  FramePoseSummary fs;
  const std::vector<StampedPose> between_axis =
      RefineFramePoses(o.frames, bo, f.between, keyframes_axis, map, r.camera, &fs);
  spdlog::info(
      "track: {} frames between keyframes resected ({} interpolated), {:.3f}° from "
      "interpolation, rms {:.2f} px",
      fs.refined, fs.interpolated, fs.mean_change_deg, fs.mean_rms_px);
  timing["frame_poses_s"] = clock.Lap();

  // Plot frame: up along the axis, origin on the ground below it.
  std::vector<Eigen::Vector3d> pts_axis;
  for (size_t t = 0; t < map.point_world.size(); ++t) {
    if (map.point_valid[t]) pts_axis.push_back(map.point_world[t]);
  }
  const GroundFit ground = FitGround(o.ground, pts_axis);
  double ground_z = ground.found ? ground.height_at_axis_m : -1.3;
  if (o.camera_height_m > 0) {
    ground_z = -o.camera_height_m;
  } else if (!ground.found) {
    spdlog::warn(
        "track: no ground plane found; assuming the camera at 1.3 m (give --camera-height)");
  }
  const Eigen::Vector3d forward0 = map.cam_from_world[0].conjugate() * Eigen::Vector3d::UnitZ();
  VerticalEstimate vertical;  // the axis, for a levelled tripod
  if (o.vertical_from == VerticalSource::kTrunks) {
    vertical = EstimateVertical(o.vertical, f.keyframes, map, r.camera);
    if (!vertical.found) {
      spdlog::warn("track: too few trunk edges to find the vertical; using the rotation axis");
    }
  }
  r.plot_from_axis = PlotFromAxis(vertical.up_axis, ground_z, forward0);
  timing["plot_frame_s"] = clock.Lap();
  for (size_t k = 0; k < map.centre_world.size(); ++k) {
    const Rigid3d axis_from_cam{map.cam_from_world[k].conjugate(), map.centre_world[k]};
    r.keyframes.push_back({f.keyframes[k].t_s, r.plot_from_axis * axis_from_cam});
    r.keyframe_images.push_back(f.keyframes[k].bgr);
    r.keyframe_gray_full.push_back(f.keyframes[k].gray_full);
  }
  for (const Eigen::Vector3d& p : pts_axis) r.points_plot.push_back(r.plot_from_axis * p);
  std::vector<StampedPose> stamped = r.keyframes;
  for (const StampedPose& p : between_axis) {
    stamped.push_back({p.t_s, r.plot_from_axis * p.world_from_cam});
  }
  std::stable_sort(stamped.begin(), stamped.end(),
                   [](const StampedPose& a, const StampedPose& b) { return a.t_s < b.t_s; });
  r.frames = InterpolatePoses(f.frame_t_s, stamped);

  double r_fit = 0.0;
  for (const Eigen::Vector3d& c : map.centre_world) r_fit += c.head<2>().norm();
  r_fit /= map.centre_world.size();
  nlohmann::json& s = r.summary;
  s["video"] = {{"width", f.info.width},
                {"height", f.info.height},
                {"fps", f.info.fps},
                {"codec", f.info.codec},
                {"creation_time", f.info.creation_time},
                {"frames", f.frame_t_s.size()},
                {"rotation_deg", f.info.rotation_deg},
                {"corrupt_packets", f.corrupt_packets},
                {"damaged_frames", f.damaged_frames},
                {"damaged_spans_s", f.damaged_spans_s},
                {"header_duration_s", f.info.duration_s},
                {"incomplete", EndsEarly(f)},
                {"bridged_spans_s", bridged},
                {"dark_frames", f.dark_frames}};
  s["camera"] = r.camera;
  s["focal_refined"] = bo.refine_focal;
  s["keyframe_focal_max_stray_pct"] = focal_max_stray_pct;
  s["breathing_keyframes"] = breathing_keyframes;
  s["breathing_corrected"] = !r.keyframe_focal_scale.empty();
  if (!r.keyframe_focal_scale.empty()) s["keyframe_focal_scale"] = r.keyframe_focal_scale;
  s["hfov_initial_deg"] = initial_hfov_deg;
  s["hfov_deg"] = r.camera.HfovDeg();
  s["keyframes"] = f.keyframes.size();
  s["tracks"] = f.tracks.size();
  s["mean_tracked_points"] = f.mean_tracked_points;
  s["turn_deg"] = turn_deg;
  s["direction"] = phi.back() >= 0 ? "counter-clockwise" : "clockwise";
  s["apparent_turn_factor"] = loop.apparent_per_turn_rad / (2.0 * M_PI);
  s["warnings"] = nlohmann::json::array();
  if (!focal_warning.empty()) s["warnings"].push_back(focal_warning);
  s["loop_pairs"] = loop.pairs.size();
  s["observations_refined"] = refine_report;
  s["loop_merged_tracks"] = loop.merged_tracks + loop.extended_tracks;
  s["loop_error_before_deg"] = MeanOdometryLoopErrorDeg(loop, turn);
  s["loop_error_after_deg"] = MeanLoopErrorDeg(loop, map);
  s["loop_closed"] = !loop.pairs.empty() && s["loop_error_after_deg"].get<double>() < 0.2;
  s["bundle_adjustment"] = rounds;
  s["reprojection_rms_px"] = bs.final_rms_px;
  s["frames_resected"] = fs.refined;
  s["frames_interpolated"] = fs.interpolated;
  s["frame_resection_rms_px"] = fs.mean_rms_px;
  s["points"] = pts_axis.size();
  s["arm_radius_m"] = o.arm_radius_m;
  s["circle_fit_radius_m"] = r_fit;
  s["paper_scale_factor"] = o.arm_radius_m / r_fit;  // r_real / r_est, as in the paper
  s["ground_found"] = ground.found;
  s["ground_slope_deg"] = ground.slope_deg;
  s["camera_height_m"] = -ground_z;
  s["camera_height_source"] = o.camera_height_m > 0 ? "measured" : "estimated";
  s["camera_height_estimated_m"] = ground.found ? -ground.height_at_axis_m : 0.0;
  s["vertical_from"] = VerticalSourceName(o.vertical_from);
  s["vertical_found"] = vertical.found;
  s["vertical_segments"] = vertical.segments;
  s["vertical_trunks"] = vertical.trunks;
  s["stand_tilt_deg"] = vertical.tilt_deg;
  const Eigen::Quaterniond& pa = r.plot_from_axis.rotation;
  s["plot_from_axis"] = {{"qx", pa.x()},
                         {"qy", pa.y()},
                         {"qz", pa.z()},
                         {"qw", pa.w()},
                         {"t",
                          {r.plot_from_axis.translation.x(), r.plot_from_axis.translation.y(),
                           r.plot_from_axis.translation.z()}}};
  s["timing_s"] = timing;

  WriteTrackOutputs(out_dir, r, ToJson(o));
  s["timing_s"]["write_s"] = clock.Lap();
  return r;
}

}  // namespace stemmap::track
