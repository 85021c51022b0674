#include "stemmap/sim/truth.h"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <vector>

#include "stemmap/core/io.h"

namespace stemmap::sim {

namespace {

constexpr double kRad2Deg = 180.0 / std::numbers::pi;

// The plot frame's x in the stand, as an angle counter-clockwise from the stand's x.
double PlotYawRad(const Rigid3d& stand_from_plot) {
  const Eigen::Vector3d x = stand_from_plot.rotation * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

nlohmann::json TreeJson(const SceneTree& t, const Rigid3d& stand_from_plot) {
  const Stem& stem = t.stem;
  const StemParams& p = stem.params();
  const Eigen::Vector3d stand_bh = stem.AxisPoint(p.s_bh_m);
  const Eigen::Vector3d bh = stand_from_plot.Inverse() * stand_bh;
  // Seen from the plot centre: the width a silhouette shows, which an elliptic stem makes differ
  // from the girth's diameter.
  const Eigen::Vector2d from_centre =
      (stand_bh.head<2>() - stand_from_plot.translation.head<2>()).normalized();
  const Stem::Section sec = stem.MeasureSection(p.s_bh_m, from_centre);
  const double turn_rad = PlotYawRad(stand_from_plot);
  return {{"id", t.id},
          {"x_m", bh.x()},
          {"y_m", bh.y()},
          {"z_m", bh.z()},
          {"dbh_cm", 100.0 * sec.girth_m / std::numbers::pi},
          {"major_cm", 100.0 * sec.major_m},
          {"minor_cm", 100.0 * sec.minor_m},
          {"width_from_centre_cm", 100.0 * sec.across_m},
          {"lean_deg", p.lean_rad * kRad2Deg},
          {"lean_azimuth_deg", (p.lean_azimuth_rad - turn_rad) * kRad2Deg},
          {"distance_m", bh.head<2>().norm()},
          {"azimuth_deg", std::atan2(bh.y(), bh.x()) * kRad2Deg},
          {"height_m", p.height_m}};
}

}  // namespace

void WriteTruth(const std::filesystem::path& path, const Scene& scene, const PinholeCamera& camera,
                const RigParams& rig, const std::vector<RigFrame>& frames, uint64_t seed,
                const Rigid3d& stand_from_plot, const nlohmann::json& camera_extra) {
  nlohmann::json j;
  j["format"] = "stemmap-truth/1";
  j["frame"] =
      "plot frame: origin on the rotation axis at ground level, z up, x along the first "
      "frame's horizontal viewing direction; poses are world_from_camera with OpenCV camera axes";
  j["seed"] = seed;
  j["kind"] = ToString(scene.kind);
  nlohmann::json cam = camera;
  cam["hfov_deg"] = camera.HfovDeg();
  cam["distortion"] = {camera.k1, camera.k2, 0.0, 0.0, camera.k3};  // OpenCV's order
  if (camera.HasDistortion()) cam["lens_hfov_deg"] = camera.LensHfovDeg();
  if (camera_extra.is_object()) cam.update(camera_extra);
  j["intrinsics"] = cam;
  j["arm_radius_m"] = rig.arm_radius_m;
  j["camera_height_m"] = rig.camera_height_m;
  j["fps"] = rig.fps;
  j["frame_count"] = frames.size();
  j["rig"] = {{"turns", rig.turns},
              {"seconds", rig.seconds},
              {"direction", rig.direction > 0 ? "counter-clockwise" : "clockwise"},
              {"stand_tilt_deg", rig.stand_tilt_deg},
              {"mount_pitch_deg", rig.mount_pitch_deg},
              {"mount_roll_deg", rig.mount_roll_deg},
              {"mount_yaw_deg", rig.mount_yaw_deg},
              {"wobble_m", rig.wobble_m},
              {"wobble_deg", rig.wobble_deg}};
  j["breast_height_m"] = kBreastHeightM;
  j["ground_slope_deg"] = scene.ground.slope_deg();
  const Eigen::Vector3d s = stand_from_plot.rotation.conjugate() * scene.light.sun_dir_world;
  const Eigen::Vector3d& o = stand_from_plot.translation;
  j["stand_from_plot"] = {{"x_m", o.x()},
                          {"y_m", o.y()},
                          {"z_m", o.z()},
                          {"yaw_deg", PlotYawRad(stand_from_plot) * kRad2Deg}};
  j["sun"] = {{"elevation_deg", std::asin(s.z()) * kRad2Deg},
              {"azimuth_deg", std::atan2(s.y(), s.x()) * kRad2Deg}};
  j["trees"] = nlohmann::json::array();
  j["saplings"] = nlohmann::json::array();
  // Each tree's section is measured on its own (2880 samples of its bark): in parallel, listed in
  // order.
  std::vector<nlohmann::json> tree_json(scene.trees.size());
#pragma omp parallel for schedule(dynamic)
  for (size_t i = 0; i < scene.trees.size(); ++i) {
    tree_json[i] = TreeJson(scene.trees[i], stand_from_plot);
  }
  for (size_t i = 0; i < scene.trees.size(); ++i) {
    (scene.trees[i].sapling ? j["saplings"] : j["trees"]).push_back(std::move(tree_json[i]));
  }
  j["shrubs"] = scene.shrubs.size();
  nlohmann::json poses = nlohmann::json::array();
  for (size_t i = 0; i < frames.size(); ++i) {
    const auto& q = frames[i].world_from_cam.rotation;
    const auto& t = frames[i].world_from_cam.translation;
    poses.push_back({{"frame", i},
                     {"t_s", frames[i].t_s},
                     {"t_xyz", {t.x(), t.y(), t.z()}},
                     {"q_xyzw", {q.x(), q.y(), q.z(), q.w()}}});
  }
  j["poses"] = poses;
  WriteJsonAtomic(path, j);
}

void WriteFramesTruth(const std::filesystem::path& path, const std::vector<RigFrame>& frames,
                      const std::vector<PinholeCamera>& cameras,
                      const std::vector<double>& focus_m) {
  // Round-trip digits: a reader sees the very intrinsics each frame was rendered with.
  std::string csv = focus_m.empty() ? "frame,t_s,fx,fy,cx,cy\n" : "frame,t_s,fx,fy,cx,cy,focus_m\n";
  for (size_t i = 0; i < frames.size() && i < cameras.size(); ++i) {
    const PinholeCamera& c = cameras[i];
    csv += fmt::format("{},{},{},{},{},{}", i, frames[i].t_s, c.fx, c.fy, c.cx, c.cy);
    csv += i < focus_m.size() ? fmt::format(",{}\n", focus_m[i]) : "\n";
  }
  WriteFileAtomic(path, csv);
}

}  // namespace stemmap::sim
