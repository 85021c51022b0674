#include "stemmap/track/frame_poses.h"

#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/track/residuals.h"

namespace stemmap::track {

void FramePoseOptions::Check() const {
  if (min_points < 6) throw InputError("frame poses need at least 6 points");
  if (!(inlier_px > 0 && max_change_deg > 0)) {
    throw InputError("frame pose thresholds must be positive");
  }
}

std::vector<StampedPose> InterpolatePoses(const std::vector<double>& t_s,
                                          const std::vector<StampedPose>& poses) {
  std::vector<StampedPose> out(t_s.size());
  if (poses.empty()) return out;
  size_t k = 0;
  for (size_t i = 0; i < t_s.size(); ++i) {
    const double t = t_s[i];
    while (k + 2 < poses.size() && poses[k + 1].t_s <= t) ++k;
    const StampedPose &a = poses[k], &b = poses[std::min(k + 1, poses.size() - 1)];
    double w = b.t_s > a.t_s ? (t - a.t_s) / (b.t_s - a.t_s) : 0.0;
    w = std::clamp(w, 0.0, 1.0);
    out[i].t_s = t;
    out[i].world_from_cam.rotation = a.world_from_cam.rotation.slerp(w, b.world_from_cam.rotation);
    out[i].world_from_cam.translation =
        (1.0 - w) * a.world_from_cam.translation + w * b.world_from_cam.translation;
  }
  return out;
}

namespace {

struct Resected {
  StampedPose pose;
  bool refined = false;
  double change_deg = 0.0, rms_px = 0.0;
};

// Inliers of `pose` (world_from_cam) among the frame's observations of valid points.
int CountInliers(const FramePoseOptions& o, const FrameObservations& b, const SparseMap& map,
                 const PinholeCamera& camera, double focal_scale, const Rigid3d& world_from_cam,
                 double* sq_sum) {
  const Rigid3d cam_from_world = world_from_cam.Inverse();
  int n = 0;
  *sq_sum = 0.0;
  for (size_t i = 0; i < b.track.size(); ++i) {
    const int t = b.track[i];
    if (!map.point_valid[t]) continue;
    const Eigen::Vector3d p = cam_from_world * map.point_world[t];
    if (p.z() <= 1e-6) continue;
    const Eigen::Vector3d ray = camera.CamRayFromImage(b.px[i].cast<double>());
    const double e = camera.fx * (focal_scale * p.head<2>() / p.z() - ray.head<2>()).norm();
    if (e > o.inlier_px) continue;
    *sq_sum += e * e;
    ++n;
  }
  return n;
}

// The frame's pose against the map's points, at `focal_scale` times the camera's focal length.
Resected Resect(const FramePoseOptions& o, const BundleOptions& bo, const FrameObservations& b,
                const StampedPose& initial, const SparseMap& map, const PinholeCamera& camera,
                double focal_scale) {
  Resected r{initial};
  Eigen::Quaterniond q = initial.world_from_cam.rotation.conjugate();  // cam_from_world
  Eigen::Vector3d c = initial.world_from_cam.translation;
  Eigen::Quaterniond mount = map.arm_from_cam;
  std::vector<Eigen::Vector3d> points;
  points.reserve(b.track.size());
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  ceres::EigenQuaternionManifold quaternion_manifold;
  for (size_t i = 0; i < b.track.size(); ++i) {
    const int t = b.track[i];
    if (map.point_valid[t]) points.push_back(map.point_world[t]);
  }
  if (static_cast<int>(points.size()) < o.min_points) return r;
  // Created only now: the problem owns a loss once a residual uses it.
  ceres::LossFunction* loss = new ceres::HuberLoss(bo.loss_px);
  size_t j = 0;
  for (size_t i = 0; i < b.track.size(); ++i) {
    if (!map.point_valid[b.track[i]]) continue;
    const Eigen::Vector3d ray = camera.CamRayFromImage(b.px[i].cast<double>());
    problem.AddResidualBlock(
        ReprojectionError::Create(ray.head<2>(), camera.fx, {camera.k1, camera.k2, camera.k3}),
        loss, q.coeffs().data(), c.data(), points[j].data(), &focal_scale);
    problem.SetParameterBlockConstant(points[j++].data());
  }
  problem.SetParameterBlockConstant(&focal_scale);
  ceres::LossFunction* prior_loss = new ceres::HuberLoss(3.0);
  problem.AddResidualBlock(
      CirclePriorError::Create(bo.arm_radius_m, bo.sigma_radius_m, bo.sigma_height_m), prior_loss,
      c.data());
  problem.AddResidualBlock(MountPriorError::Create(bo.sigma_mount_deg * M_PI / 180.0), prior_loss,
                           q.coeffs().data(), c.data(), mount.coeffs().data());
  problem.SetParameterBlockConstant(mount.coeffs().data());
  problem.SetManifold(q.coeffs().data(), &quaternion_manifold);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 15;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!q.coeffs().allFinite() || !c.allFinite()) return r;

  const Rigid3d refined{q.normalized().conjugate(), c};
  double sq = 0.0;
  const int inliers = CountInliers(o, b, map, camera, focal_scale, refined, &sq);
  r.change_deg = refined.rotation.angularDistance(initial.world_from_cam.rotation) * 180.0 / M_PI;
  if (inliers < o.min_points || r.change_deg > o.max_change_deg) return r;
  r.pose.world_from_cam = refined;
  r.refined = true;
  r.rms_px = std::sqrt(sq / inliers);
  return r;
}

// Each frame's focal length over the camera's: where the keyframes have their own (focus
// breathing), the nearest keyframes' interpolated in time; 1 otherwise.
std::vector<double> FrameFocalScales(const std::vector<double>& t_s,
                                     const std::vector<StampedPose>& keyframes,
                                     const SparseMap& map) {
  std::vector<double> scales(t_s.size(), 1.0);
  if (map.keyframe_focal_scale.size() != keyframes.size() || keyframes.empty()) return scales;
  for (size_t i = 0; i < t_s.size(); ++i) {
    const auto after = std::lower_bound(keyframes.begin(), keyframes.end(), t_s[i],
                                        [](const StampedPose& k, double t) { return k.t_s < t; });
    const size_t b = std::min<size_t>(after - keyframes.begin(), keyframes.size() - 1);
    const size_t a = b > 0 ? b - 1 : 0;
    const double span = keyframes[b].t_s - keyframes[a].t_s;
    const double w = span > 0 ? std::clamp((t_s[i] - keyframes[a].t_s) / span, 0.0, 1.0) : 1.0;
    scales[i] = map.FocalScaleAt(static_cast<int>(a)) * (1.0 - w) +
                map.FocalScaleAt(static_cast<int>(b)) * w;
  }
  return scales;
}

}  // namespace

std::vector<StampedPose> RefineFramePoses(const FramePoseOptions& o, const BundleOptions& bo,
                                          const std::vector<FrameObservations>& between,
                                          const std::vector<StampedPose>& keyframes_axis,
                                          const SparseMap& map, const PinholeCamera& camera,
                                          FramePoseSummary* summary) {
  o.Check();
  std::vector<double> t_s;
  for (const FrameObservations& b : between) t_s.push_back(b.t_s);
  const std::vector<StampedPose> initial = InterpolatePoses(t_s, keyframes_axis);
  const std::vector<double> focal_scale = FrameFocalScales(t_s, keyframes_axis, map);
  std::vector<Resected> res(between.size());
  if (o.enabled) {
#pragma omp parallel for schedule(dynamic, 8) num_threads(std::max(1, o.threads))
    for (int i = 0; i < static_cast<int>(between.size()); ++i) {
      res[i] = Resect(o, bo, between[i], initial[i], map, camera, focal_scale[i]);
    }
  } else {
    for (size_t i = 0; i < between.size(); ++i) res[i].pose = initial[i];
  }
  FramePoseSummary s;
  std::vector<StampedPose> out;
  out.reserve(res.size());
  for (const Resected& r : res) {
    out.push_back(r.pose);
    if (!r.refined) {
      ++s.interpolated;
      continue;
    }
    ++s.refined;
    s.mean_change_deg += r.change_deg;
    s.mean_rms_px += r.rms_px;
  }
  if (s.refined) {
    s.mean_change_deg /= s.refined;
    s.mean_rms_px /= s.refined;
  }
  if (summary) *summary = s;
  return out;
}

}  // namespace stemmap::track
