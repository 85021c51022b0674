#include "stemmap/sim/simulate.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <thread>

#include "stemmap/camera/camera.h"
#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/progress.h"
#include "stemmap/core/rng.h"
#include "stemmap/core/units.h"
#include "stemmap/sim/board.h"
#include "stemmap/sim/render.h"
#include "stemmap/sim/rig.h"
#include "stemmap/sim/sensor.h"
#include "stemmap/sim/truth.h"
#include "stemmap/sim/wind.h"
#include "stemmap/video/video_writer.h"

namespace stemmap::sim {

namespace fs = std::filesystem;

namespace {

// Rendered frames on their way to the sensor model, at most `capacity` at once.
class RenderQueue {
 public:
  struct Item {
    size_t index;
    RenderBuffers buffers;
  };
  explicit RenderQueue(size_t capacity) : capacity_(capacity) {}

  // False when the consumer gave up (Abort).
  bool Push(Item item) {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return aborted_ || items_.size() < capacity_; });
    if (aborted_) return false;
    items_.push_back(std::move(item));
    changed_.notify_all();
    return true;
  }
  // The next item in order, or nullopt once the producer closed the queue and it is empty.
  std::optional<Item> Pop() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return closed_ || !items_.empty(); });
    if (items_.empty()) return std::nullopt;
    Item item = std::move(items_.front());
    items_.pop_front();
    changed_.notify_all();
    return item;
  }
  void Close() {
    const std::lock_guard lock(mutex_);
    closed_ = true;
    changed_.notify_all();
  }
  void Abort() {
    const std::lock_guard lock(mutex_);
    aborted_ = true;
    changed_.notify_all();
  }

 private:
  size_t capacity_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Item> items_;
  bool closed_ = false, aborted_ = false;
};

}  // namespace

void SimulateOptions::Check() const {
  if (out_dir.empty()) throw InputError("simulate needs an output folder (--out)");
  if (width < 64 || height < 64 || width > 4096 || height > 4096 || width % 2 || height % 2) {
    throw InputError(
        fmt::format("frame size {}x{}: use even sizes from 64 to 4096", width, height));
  }
  if (!(fps >= 1 && fps <= 120)) throw InputError(fmt::format("fps {} out of [1, 120]", fps));
  if (seconds < 0 || seconds > 600) throw InputError("seconds must be in (0, 600]");
  if (turns < 0 || turns > 3) throw InputError("turns must be in (0, 3]");
  if (!(stand_tilt_deg <= 10)) throw InputError("the stand's tilt must be at most 10 degrees");
  if (!(arm_radius_m >= 0.2 && arm_radius_m <= 3.0)) {
    throw InputError(fmt::format("arm radius {} m out of [0.2, 3]", arm_radius_m));
  }
  if (hfov_deg != 0 && !(hfov_deg >= 20 && hfov_deg <= 120)) {
    throw InputError(fmt::format("hfov {}° out of [20, 120]", hfov_deg));
  }
  if (!(std::abs(k1) <= 0.3)) throw InputError("|k1| must be at most 0.3");
  if (!(std::abs(k2) <= 0.3)) throw InputError("|k2| must be at most 0.3");
  if (!(std::abs(k3) <= 0.1)) throw InputError("|k3| must be at most 0.1");
  phone.Check();
  if (phone.readout_ms > 1000.0 / fps) {
    throw InputError(
        fmt::format("--readout-ms {} is longer than a frame at {} fps", phone.readout_ms, fps));
  }
  // The lens must show its field without folding over (the widest drawn one when none is given).
  PinholeCamera::FromLensHfov(width, height, hfov_deg > 0 ? hfov_deg : 75.0, k1, k2, k3).Check();
  if (stills < 0 || stills > 20) throw InputError("stills must be in [0, 20]");
  if (checkerboard && truth_only) {
    throw InputError("--checkerboard renders the board video; --truth-only renders nothing");
  }
  if (!std::isfinite(start_deg)) throw InputError("--start-deg must be a number of degrees");
  // The scene reaches 40 m around the stand's centre; a plot of 11 m must lie within it.
  if (!(std::hypot(centre_offset_x_m, centre_offset_y_m) <= 10.0)) {
    throw InputError("--centre-offset must lie within 10 m of the stand's centre");
  }
}

std::string SimulateSummary::BriefReport() const {
  return fmt::format(
      "{} frames ({:.1f} s of video), {} trees within 10 m ({} in the scene), "
      "rendered in {:.1f} s (render {:.1f}, sensor {:.1f}, encode {:.1f})",
      frames, seconds, plot_trees, all_trees, wall_s, render_s, sensor_s, encode_s);
}

void to_json(nlohmann::json& j, const SimulateOptions& o) {
  j = {{"seed", o.seed},
       {"kind", ToString(o.kind)},
       {"width", o.width},
       {"height", o.height},
       {"fps", o.fps},
       {"seconds", o.seconds},
       {"turns", o.turns},
       {"arm_radius_m", o.arm_radius_m},
       {"stand_tilt_deg", o.stand_tilt_deg},
       {"hfov_deg", o.hfov_deg},
       {"k1", o.k1},
       {"k2", o.k2},
       {"k3", o.k3},
       {"phone", o.phone},
       {"bitrate_mbps", o.bitrate_mbps},
       {"layout_csv", o.layout_csv.string()},
       {"layout_plot", o.layout_plot},
       {"stills", o.stills},
       {"truth_only", o.truth_only},
       {"checkerboard", o.checkerboard},
       {"start_deg", o.start_deg},
       {"centre_offset_m", {o.centre_offset_x_m, o.centre_offset_y_m}}};
}

namespace {

// The board video of the plot's camera (rolling shutter, breathing and stabilisation left out: a
// board held still before a phone whose settings the README fixes), and its camera as truth.
SimulateSummary WriteCheckerboard(const SimulateOptions& o, const PinholeCamera& camera,
                                  std::chrono::steady_clock::time_point start) {
  std::filesystem::create_directories(o.out_dir);
  const BoardVideoOptions board;
  const double bitrate_mbps =
      o.bitrate_mbps > 0 ? o.bitrate_mbps : 17.0 * (o.width * o.height) / (1920.0 * 1080.0);
  WriteBoardVideo(board, camera, o.seed, bitrate_mbps, o.out_dir / "video.mp4");
  nlohmann::json truth = {{"format", "stemmap-board-truth-1"},
                          {"seed", o.seed},
                          {"intrinsics", camera},
                          {"inner_corners", {board.inner_cols, board.inner_rows}},
                          {"square_m", board.square_m},
                          {"views", board.views},
                          {"fps", board.fps}};
  WriteJsonAtomic(o.out_dir / "board_truth.json", truth);
  SimulateSummary summary;
  summary.frames = board.views;
  summary.seconds = board.views / board.fps;
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace

SimulateSummary RunSimulate(const SimulateOptions& o) {
  o.Check();
  const auto start = std::chrono::steady_clock::now();
  Rng rng(HashCombine(o.seed, 0xC0FFEE));

  SceneOptions scene_options;
  scene_options.kind = o.kind;
  scene_options.seed = o.seed;
  if (!o.layout_csv.empty()) scene_options.layout = ReadLayoutCsv(o.layout_csv, o.layout_plot);
  const Scene scene = GenerateScene(scene_options);

  const PhoneOptions& phone = o.phone;
  PinholeCamera camera = PinholeCamera::FromLensHfov(
      o.width, o.height, o.hfov_deg > 0 ? o.hfov_deg : rng.Uniform(60.0, 75.0), o.k1, o.k2, o.k3);
  camera.cx += rng.Uniform(-0.01, 0.01) * o.width;
  camera.cy += rng.Uniform(-0.01, 0.01) * o.height;
  if (phone.stabilisation) {
    // The video is a crop of the sensor's image, scaled up to the frame size.
    camera.fx *= phone.stabilisation_crop;
    camera.fy *= phone.stabilisation_crop;
  }
  camera.Check();
  if (o.checkerboard) return WriteCheckerboard(o, camera, start);

  RigParams rig;
  rig.arm_radius_m = o.arm_radius_m;
  rig.camera_height_m = rng.Uniform(1.25, 1.40);
  rig.seconds = o.seconds > 0 ? o.seconds : rng.Uniform(40.0, 50.0);
  rig.turns = o.turns > 0 ? o.turns : rng.Uniform(1.05, 1.15);
  rig.fps = o.fps;
  rig.stand_tilt_deg = rng.Uniform(0.0, 1.5);  // drawn always: the draws after stay the seed's
  if (o.stand_tilt_deg >= 0) rig.stand_tilt_deg = o.stand_tilt_deg;
  rig.stand_tilt_azimuth_rad = rng.Uniform(0, 2 * std::numbers::pi);
  rig.mount_pitch_deg = std::clamp(rng.Normal(0, 1.5), -3.0, 3.0);
  rig.mount_roll_deg = std::clamp(rng.Normal(0, 0.8), -1.5, 1.5);
  rig.mount_yaw_deg = std::clamp(rng.Normal(0, 1.0), -2.0, 2.0);
  rig.direction = rng.Bernoulli(0.5) ? 1 : -1;
  rig.seed = rng.NextU64();
  const RigMotion motion(rig);
  const std::vector<RigFrame> frames = motion.Frames();
  // The capture's plot frame in the stand: the rig turns about the tripod, on the stand's ground.
  Rigid3d stand_from_plot;
  stand_from_plot.rotation = Eigen::AngleAxisd(o.start_deg * kDeg, Eigen::Vector3d::UnitZ());
  stand_from_plot.translation = {o.centre_offset_x_m, o.centre_offset_y_m,
                                 scene.ground.Height(o.centre_offset_x_m, o.centre_offset_y_m)};

  SensorParams sensor_params;
  sensor_params.exposure_time_s = 1.0 / rng.Uniform(60.0, 120.0);
  sensor_params.seed = rng.NextU64();
  SensorModel sensor(sensor_params, camera);

  // The renderer is built before the truth where the autofocus, which the truth records, meters
  // the scene.
  std::optional<Renderer> renderer;
  if (!o.truth_only || phone.breathing_pct > 0) renderer.emplace(scene, camera, RenderOptions{});
  std::optional<Wind> wind;
  if (phone.wind > 0) wind.emplace(scene, phone.wind, o.seed);
  // Each frame as the phone takes it; with every effect off, a global shutter at `camera`.
  std::vector<PinholeCamera> frame_cameras;  // empty: every frame at `camera`
  const auto frame_setup = [&](size_t i, bool rows) {
    FrameSetup f;
    f.world_from_cam = stand_from_plot * frames[i].world_from_cam;
    if (i < frame_cameras.size()) f.camera = frame_cameras[i];
    if (wind) f.sway = wind->At(frames[i].t_s);
    if (rows && phone.readout_ms > 0) {
      f.world_from_row_cam.resize(o.height);
      for (int v = 0; v < o.height; ++v) {
        const double t_s = frames[i].t_s + 1e-3 * phone.readout_ms *
                                               (static_cast<double>(v) / (o.height - 1) - 0.5);
        f.world_from_row_cam[v] = stand_from_plot * motion.WorldFromCam(t_s);
      }
    }
    return f;
  };
  std::vector<double> focus_m;
  if (phone.PerFrameIntrinsics()) {
    const double crop = phone.stabilisation ? phone.stabilisation_crop : 1.0;
    const std::vector<Eigen::Vector2d> jitter =
        phone.stabilisation ? RotationJitter(frames, o.fps, phone.stabilisation_window_s)
                            : std::vector<Eigen::Vector2d>(frames.size(), Eigen::Vector2d::Zero());
    std::optional<Autofocus> autofocus;
    for (size_t i = 0; i < frames.size(); ++i) {
      double scale = 1.0;
      if (phone.breathing_pct > 0) {
        // Focused on the first view before the recording starts; then each frame follows what
        // the frame before it metered.
        if (i == 0) {
          autofocus.emplace(phone.focus_lag_s, renderer->CentreDepth(frame_setup(0, false)));
        } else {
          autofocus->Update(renderer->CentreDepth(frame_setup(i - 1, false)), 1.0 / o.fps);
        }
        focus_m.push_back(autofocus->focus_m());
        scale = BreathingScale(autofocus->focus_m(), phone.breathing_pct);
      }
      frame_cameras.push_back(FrameCamera(camera, scale, jitter[i], crop));
    }
  }

  fs::create_directories(o.out_dir);
  WriteJsonAtomic(o.out_dir / "simulate_options.json", nlohmann::json(o));
  nlohmann::json camera_truth;
  if (phone.Any() || phone.preset != PhonePreset::kIdeal) {
    camera_truth["phone"] = phone;
    camera_truth["row_time"] =
        "row v of a frame taken at t_s + readout_ms / 1000 * (v / (height - 1) - 1/2): the poses "
        "are the middle row's";
  }
  if (!frame_cameras.empty()) {
    camera_truth["frames_truth"] = "frames_truth.csv";
    WriteFramesTruth(o.out_dir / "frames_truth.csv", frames, frame_cameras, focus_m);
  }
  WriteTruth(o.out_dir / "truth.json", scene, camera, rig, frames, o.seed, stand_from_plot,
             camera_truth);
  std::vector<StampedPose> poses;
  for (const RigFrame& f : frames) poses.push_back({f.t_s, f.world_from_cam});
  WriteTumTrajectory(o.out_dir / "trajectory_truth.tum", poses);
  SimulateSummary summary;
  summary.frames = static_cast<int>(frames.size());
  summary.seconds = frames.size() / o.fps;
  for (const SceneTree& t : scene.trees) {
    if (t.sapling) continue;
    ++summary.all_trees;
    const Eigen::Vector3d bh = stand_from_plot.Inverse() * t.stem.AxisPoint(t.stem.params().s_bh_m);
    if (bh.head<2>().norm() <= 10.0) ++summary.plot_trees;
  }
  if (o.truth_only) {
    summary.wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return summary;
  }

  VideoWriterOptions vw;
  vw.width = o.width;
  vw.height = o.height;
  vw.fps = o.fps;
  vw.bitrate_mbps = o.bitrate_mbps > 0 ? o.bitrate_mbps
                                       : 17.0 * (o.width * o.height) / (1920.0 * 1080.0) *
                                             std::max(0.5, o.fps / 30.0);
  VideoWriter writer(o.out_dir / "video.mp4", vw);
  std::vector<int> still_frames;
  for (int k = 0; k < o.stills; ++k) {
    still_frames.push_back(static_cast<int>(frames.size()) * k / std::max(o.stills, 1));
  }
  Progress progress("simulate", static_cast<int64_t>(frames.size()));
  // The sensor model and the encoder take frame i on their own thread while frame i + 1 renders:
  // they fill the moments the renderer's threads wait for each other. One consumer keeps the
  // frame order, which the auto-exposure (state carried from frame to frame) and the file need.
  RenderQueue queue(2);
  std::exception_ptr develop_error;
  std::thread develop([&] {
    try {
      while (std::optional<RenderQueue::Item> item = queue.Pop()) {
        const size_t i = item->index;
        const auto t1 = std::chrono::steady_clock::now();
        const cv::Mat bgr = sensor.Capture(item->buffers, frames[i].yaw_rate_rad_s, o.arm_radius_m,
                                           static_cast<int>(i), 1.0 / o.fps);
        const auto t2 = std::chrono::steady_clock::now();
        writer.Write(bgr);
        const auto t3 = std::chrono::steady_clock::now();
        summary.sensor_s += std::chrono::duration<double>(t2 - t1).count();
        summary.encode_s += std::chrono::duration<double>(t3 - t2).count();
        if (std::find(still_frames.begin(), still_frames.end(), static_cast<int>(i)) !=
            still_frames.end()) {
          const fs::path png = o.out_dir / "stills" / fmt::format("frame_{:05d}.png", i);
          fs::create_directories(png.parent_path());
          std::vector<uchar> buf;
          cv::imencode(".png", bgr, buf);
          WriteFileAtomic(png,
                          std::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
        }
        progress.Update(static_cast<int64_t>(i + 1));
      }
    } catch (...) {
      develop_error = std::current_exception();
      queue.Abort();
    }
  });
  {
    // Whatever happens here, the developing thread is told no more frames come, and waited for.
    struct JoinOnExit {
      RenderQueue& queue;
      std::thread& thread;
      ~JoinOnExit() {
        queue.Close();
        thread.join();
      }
    } join_on_exit{queue, develop};
    for (size_t i = 0; i < frames.size(); ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      RenderBuffers buffers = renderer->Render(frame_setup(i, true));
      summary.render_s +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (!queue.Push({i, std::move(buffers)})) break;  // the developing thread failed
    }
  }
  if (develop_error) std::rethrow_exception(develop_error);
  progress.Finish();
  writer.Close();
  summary.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace stemmap::sim
