#include "stemmap/track/track_io.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/progress.h"
#include "stemmap/track/keyframe_zoom.h"
#include "stemmap/track/track.h"
#include "stemmap/video/video_reader.h"

namespace stemmap::track {

void WritePointsPly(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& pts) {
  std::string s = fmt::format(
      "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n",
      pts.size());
  for (const Eigen::Vector3d& p : pts)
    s += fmt::format("{:.4f} {:.4f} {:.4f}\n", p.x(), p.y(), p.z());
  WriteFileAtomic(path, s);
}

void WriteTrackOutputs(const std::filesystem::path& out_dir, const TrackResult& r,
                       const nlohmann::json& options) {
  WriteJsonAtomic(out_dir / "track_options.json", options);
  WriteTumTrajectory(out_dir / "trajectory.tum", r.frames);
  WriteTumTrajectory(out_dir / "keyframes.tum", r.keyframes);
  WritePointsPly(out_dir / "sparse.ply", r.points_plot);
  WriteJsonAtomic(out_dir / "summary.json", {{"track", r.summary}});
}

TrackResult ReadTrackFolder(const std::filesystem::path& dir) {
  for (const char* name : {"keyframes.tum", "summary.json"}) {
    if (!std::filesystem::exists(dir / name)) {
      throw InputError(fmt::format("{} has no {}: not a track folder", dir.string(), name));
    }
  }
  TrackResult r;
  try {
    const nlohmann::json summary = ReadJsonFile(dir / "summary.json");
    r.summary = summary.at("track");
    r.camera = r.summary.at("camera").get<PinholeCamera>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(
        fmt::format("{}: no track camera in it ({})", (dir / "summary.json").string(), e.what()));
  }
  if (r.summary.contains("keyframe_focal_scale")) {
    try {
      r.keyframe_focal_scale = r.summary.at("keyframe_focal_scale").get<std::vector<double>>();
    } catch (const nlohmann::json::exception& e) {
      throw InputError(fmt::format("{}: unreadable keyframe_focal_scale ({})",
                                   (dir / "summary.json").string(), e.what()));
    }
  }
  try {
    r.camera.Check();
  } catch (const InputError& e) {
    throw InputError(fmt::format("{}: {}", (dir / "summary.json").string(), e.what()));
  }
  r.keyframes = ReadTumTrajectory(dir / "keyframes.tum");
  if (r.keyframes.size() < 3) {
    throw InputError(fmt::format("{} holds {} keyframes; a track has many more",
                                 (dir / "keyframes.tum").string(), r.keyframes.size()));
  }
  if (!r.keyframe_focal_scale.empty() && r.keyframe_focal_scale.size() != r.keyframes.size()) {
    throw InputError(fmt::format("{}: {} keyframe focal scales for {} keyframes",
                                 (dir / "summary.json").string(), r.keyframe_focal_scale.size(),
                                 r.keyframes.size()));
  }
  if (std::filesystem::exists(dir / "trajectory.tum")) {
    r.frames = ReadTumTrajectory(dir / "trajectory.tum");
  }
  for (const auto& [poses, name] :
       {std::pair{&r.keyframes, "keyframes.tum"}, std::pair{&r.frames, "trajectory.tum"}}) {
    for (size_t i = 1; i < poses->size(); ++i) {
      if (!((*poses)[i].t_s > (*poses)[i - 1].t_s)) {
        throw InputError(
            fmt::format("{}: times do not increase at pose {}", (dir / name).string(), i + 1));
      }
    }
  }
  return r;
}

TrackResult LoadTrack(const std::filesystem::path& dir, const std::filesystem::path& video,
                      bool full_gray) {
  TrackResult r = ReadTrackFolder(dir);
  VideoReaderOptions vro;
  vro.max_long_side_px = std::max(r.camera.width, r.camera.height);
  vro.full_gray = full_gray;
  vro.prefetch_frames = 8;
  // Only frames within half a frame interval of a keyframe time can be one of its images.
  std::vector<double> keyframe_t_s;
  for (const StampedPose& p : r.keyframes) keyframe_t_s.push_back(p.t_s);
  vro.wanted = [keyframe_t_s](const VideoInfo& info, int64_t, double t_s) {
    const double half_frame_s = 0.5 / (info.fps > 0 ? info.fps : 30.0);
    const auto it = std::lower_bound(keyframe_t_s.begin(), keyframe_t_s.end(), t_s - half_frame_s);
    return it != keyframe_t_s.end() && *it <= t_s + half_frame_s;
  };
  VideoReader reader(video, vro);
  const VideoInfo& info = reader.info();
  if (info.width != r.camera.width || info.height != r.camera.height) {
    throw InputError(fmt::format("the track in {} was made at {}x{}; this video decodes at {}x{}",
                                 dir.string(), r.camera.width, r.camera.height, info.width,
                                 info.height));
  }
  // Each keyframe takes the frame nearest its time, within half a frame interval.
  const double half_frame_s = 0.5 / (info.fps > 0 ? info.fps : 30.0);
  r.keyframe_images.assign(r.keyframes.size(), cv::Mat());
  if (full_gray) r.keyframe_gray_full.assign(r.keyframes.size(), cv::Mat());
  std::vector<double> gap_s(r.keyframes.size(), half_frame_s);
  Progress progress("decoding keyframes", std::max<int64_t>(1, info.frame_count));
  size_t k = 0;  // first keyframe not yet behind the current frame
  while (std::optional<DecodedFrame> f = reader.Next()) {
    progress.Update(f->index + 1);
    if (!f->converted) continue;
    while (k < r.keyframes.size() && r.keyframes[k].t_s < f->t_s - half_frame_s) ++k;
    for (size_t j = k; j < r.keyframes.size() && r.keyframes[j].t_s <= f->t_s + half_frame_s; ++j) {
      const double gap = std::abs(r.keyframes[j].t_s - f->t_s);
      if (!r.keyframe_images[j].empty() && gap >= gap_s[j]) continue;
      gap_s[j] = gap;
      r.keyframe_images[j] = f->bgr;
      if (full_gray) r.keyframe_gray_full[j] = f->gray_full;
    }
  }
  for (size_t j = 0; j < r.keyframes.size(); ++j) {
    if (r.keyframe_images[j].empty()) {
      throw InputError(fmt::format("no frame of {} at keyframe time {:.3f} s of {}: another video?",
                                   video.string(), r.keyframes[j].t_s, dir.string()));
    }
  }
  // Pictures taken while the focal length breathed, redrawn at the track's as the track did.
  for (size_t j = 0; j < r.keyframe_focal_scale.size(); ++j) {
    const double s = r.keyframe_focal_scale[j];
    r.keyframe_images[j] = UndoFocalScale(r.keyframe_images[j], r.camera, s);
    if (full_gray && !r.keyframe_gray_full[j].empty()) {
      const double to_full = static_cast<double>(r.keyframe_gray_full[j].cols) / r.camera.width;
      r.keyframe_gray_full[j] =
          UndoFocalScale(r.keyframe_gray_full[j], r.camera.Scaled(to_full), s);
    }
  }
  spdlog::info("track: {} keyframes reused from {}", r.keyframes.size(), dir.string());
  return r;
}

nlohmann::json ToJson(const TrackOptions& o) { return o; }

}  // namespace stemmap::track
