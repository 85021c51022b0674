#include "stemmap/track/track_io.h"

#include <fmt/format.h>

#include "stemmap/core/io.h"
#include "stemmap/track/track.h"

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

nlohmann::json ToJson(const TrackOptions& o) {
  const FrontendOptions& f = o.frontend;
  const BundleOptions& b = o.bundle;
  return {{"arm_radius_m", o.arm_radius_m},
          {"hfov_deg", o.hfov_deg},
          {"calibration", o.calibration.string()},
          {"focal", o.focal},
          {"camera_height_m", o.camera_height_m},
          {"min_turn_deg", o.min_turn_deg},
          {"max_dark_share", o.max_dark_share},
          {"bundle_rounds", o.bundle_rounds},
          {"frontend",
           {{"working_long_side_px", f.working_long_side_px},
            {"track_fps", f.track_fps},
            {"max_features", f.max_features},
            {"keyframe_step_deg", f.keyframe_step_deg},
            {"max_forward_backward_px", f.max_forward_backward_px},
            {"orb_features", f.orb_features}}},
          {"loop",
           {{"ratio", o.loop.ratio},
            {"threshold_deg", o.loop.threshold_deg},
            {"min_inliers", o.loop.min_inliers}}},
          {"bundle",
           {{"sigma_radius_m", b.sigma_radius_m},
            {"sigma_height_m", b.sigma_height_m},
            {"sigma_mount_deg", b.sigma_mount_deg},
            {"loss_px", b.loss_px},
            {"outlier_px", b.outlier_px},
            {"max_points", b.max_points},
            {"max_iterations", b.max_iterations},
            {"dense_schur_max_keyframes", b.dense_schur_max_keyframes},
            {"threads", b.threads}}},
          {"frames",
           {{"enabled", o.frames.enabled},
            {"min_points", o.frames.min_points},
            {"inlier_px", o.frames.inlier_px},
            {"max_change_deg", o.frames.max_change_deg}}}};
}

}  // namespace stemmap::track
