#include "stemmap/track/bundle_adjustment.h"

#include <ceres/product_manifold.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <memory>
#include <numeric>

#include "stemmap/core/error.h"
#include "stemmap/track/residuals.h"

namespace stemmap::track {

void BundleOptions::Check() const {
  if (!(arm_radius_m > 0.05 && arm_radius_m < 5.0)) {
    throw InputError(fmt::format("arm radius {} m is outside (0.05, 5) m", arm_radius_m));
  }
  if (!(sigma_radius_m > 0 && sigma_height_m > 0 && sigma_mount_deg > 0 && loss_px > 0)) {
    throw InputError("bundle adjustment sigmas must be positive");
  }
  if (!(outlier_px > 0 && max_track_rms_px >= 0)) {
    throw InputError(fmt::format(
        "the outlier threshold {} px must be positive and the tracks' rms threshold {} px at "
        "least 0",
        outlier_px, max_track_rms_px));
  }
  if (min_observations < 2) throw InputError("points need at least 2 observations");
  if (max_iterations < 1) throw InputError("bundle adjustment needs at least 1 iteration");
  if (!(min_lens_scale >= 0 && min_lens_scale < 1)) {
    throw InputError(fmt::format("the least lens scale {} is outside [0, 1)", min_lens_scale));
  }
  if (!(sigma_keyframe_focal_pct > 0 && sigma_keyframe_focal_pct <= 10)) {
    throw InputError(fmt::format("the per-keyframe focal length's SD {} % is outside (0, 10] %",
                                 sigma_keyframe_focal_pct));
  }
  if (!(function_tolerance > 0 && function_tolerance < 0.1 && early_round_function_tolerance > 0 &&
        early_round_function_tolerance < 0.1)) {
    throw InputError("bundle adjustment function tolerances must lie in (0, 0.1)");
  }
}

std::string BundleSummary::BriefReport() const {
  return fmt::format(
      "{} points, {} observations ({} rejected, {} points whose tracks move), rms {:.2f} -> "
      "{:.2f} px, {} it{}",
      points, observations, rejected_observations, rejected_points, initial_rms_px, final_rms_px,
      iterations, converged ? "" : " (not converged)");
}

Eigen::Quaterniond NominalArmFromCam() {
  Eigen::Matrix3d m;  // columns: camera x, y, z in arm axes (arm along +x, z up)
  m << 0, 0, 1,       //
      -1, 0, 0,       //
      0, -1, 0;
  return Eigen::Quaterniond(m);
}

void PlaceOnCircle(const std::vector<double>& phi, double radius_m, SparseMap* map) {
  map->arm_from_cam = NominalArmFromCam();
  map->cam_from_world.resize(phi.size());
  map->centre_world.resize(phi.size());
  for (size_t k = 0; k < phi.size(); ++k) {
    const Eigen::Quaterniond rz(Eigen::AngleAxisd(phi[k], Eigen::Vector3d::UnitZ()));
    map->cam_from_world[k] = (rz * map->arm_from_cam).conjugate();
    map->centre_world[k] = radius_m * Eigen::Vector3d(std::cos(phi[k]), std::sin(phi[k]), 0.0);
  }
}

double LensRadialScale(const PinholeCamera& camera, const Eigen::Vector2d& px) {
  if (!camera.HasDistortion()) return 1.0;
  return RadialScaleAt(RadialLens{camera.k1, camera.k2, camera.k3},
                       camera.CamRayFromImage(px).head<2>().squaredNorm());
}

double ReprojectionErrorPx(const SparseMap& map, const PinholeCamera& camera, int kf,
                           const Eigen::Vector3d& x, const Eigen::Vector2d& px) {
  const Eigen::Vector3d p = map.cam_from_world[kf] * (x - map.centre_world[kf]);
  if (p.z() <= 1e-6) return 1e9;
  const Eigen::Vector3d ray = camera.CamRayFromImage(px);
  const double k = map.FocalScaleAt(kf);
  if (!camera.HasDistortion()) {
    return camera.fx * (k * p.head<2>() / p.z() - ray.head<2>()).norm();
  }
  // As the bundle adjustment's residual: the focal scale applies to what the lens gives.
  const RadialLens lens{camera.k1, camera.k2, camera.k3};
  return camera.fx * (k * lens.Distort(p.head<2>() / p.z()) - lens.Distort(ray.head<2>())).norm();
}

std::vector<double> FocalScaleStrayPct(const std::vector<double>& scales) {
  if (scales.empty()) return {};
  std::vector<double> v = scales;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  const double median = v[mid];
  std::vector<double> stray_pct;
  for (double s : scales) stray_pct.push_back(100.0 * std::abs(s / median - 1.0));
  return stray_pct;
}

namespace {

// Camera ray through a pixel of keyframe `kf` under the map's focal scale.
Eigen::Vector3d RayOf(const SparseMap& map, const PinholeCamera& camera, int kf,
                      const Eigen::Vector2d& px) {
  const double k = map.FocalScaleAt(kf);
  if (camera.HasDistortion()) {
    // The focal scale applies to what the lens gives (ReprojectionError).
    return camera.UndistortedRay((px.x() - camera.cx) / (camera.fx * k),
                                 (px.y() - camera.cy) / (camera.fy * k));
  }
  Eigen::Vector3d ray = camera.CamRayFromImage(px);
  ray.head<2>() /= k;
  return ray;
}

}  // namespace

int TriangulateTracks(const BundleOptions& o, const std::vector<Track>& tracks,
                      const PinholeCamera& camera, SparseMap* map) {
  const size_t n = tracks.size();
  map->point_world.resize(n, Eigen::Vector3d::Zero());
  map->point_valid.resize(n, 0);
  map->obs_valid.resize(n);
  const double min_angle = o.min_triangulation_deg * M_PI / 180.0;
  int made = 0;
  for (size_t t = 0; t < n; ++t) {
    const std::vector<Observation>& obs = tracks[t].obs;
    if (map->obs_valid[t].size() != obs.size()) map->obs_valid[t].assign(obs.size(), 1);
    if (map->point_valid[t] || static_cast<int>(obs.size()) < o.min_observations) continue;
    // Midpoint of the rays: argmin_X sum |(I - d d^T)(X - c)|^2.
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    Eigen::Vector3d d_first = Eigen::Vector3d::Zero();
    double max_angle = 0.0;
    int used = 0;
    for (size_t k = 0; k < obs.size(); ++k) {
      if (!map->obs_valid[t][k]) continue;
      const int kf = obs[k].keyframe;
      const Eigen::Vector3d d =
          (map->cam_from_world[kf].conjugate() * RayOf(*map, camera, kf, obs[k].px)).normalized();
      const Eigen::Matrix3d p = Eigen::Matrix3d::Identity() - d * d.transpose();
      a += p;
      b += p * map->centre_world[kf];
      if (used == 0) d_first = d;
      max_angle = std::max(max_angle, std::acos(std::clamp(d.dot(d_first), -1.0, 1.0)));
      ++used;
    }
    if (used < o.min_observations || max_angle < min_angle) continue;
    const Eigen::Vector3d x = a.ldlt().solve(b);
    if (!x.allFinite()) continue;
    int good = 0;
    for (size_t k = 0; k < obs.size(); ++k) {
      if (!map->obs_valid[t][k]) continue;
      const double e = ReprojectionErrorPx(*map, camera, obs[k].keyframe, x, obs[k].px);
      if (e < 3.0 * o.outlier_px) ++good;
    }
    if (good < o.min_observations) continue;
    map->point_world[t] = x;
    map->point_valid[t] = 1;
    ++made;
  }
  return made;
}

namespace {

// Tracks kept in the problem: the longest first, up to max_points.
std::vector<int> SelectPoints(const BundleOptions& o, const std::vector<Track>& tracks,
                              const SparseMap& map) {
  std::vector<int> ids;
  for (size_t t = 0; t < tracks.size(); ++t) {
    if (map.point_valid[t]) ids.push_back(static_cast<int>(t));
  }
  std::stable_sort(ids.begin(), ids.end(),
                   [&](int a, int b) { return tracks[a].obs.size() > tracks[b].obs.size(); });
  if (static_cast<int>(ids.size()) > o.max_points) ids.resize(o.max_points);
  std::sort(ids.begin(), ids.end());
  return ids;
}

double RmsPx(const std::vector<Track>& tracks, const std::vector<int>& ids,
             const PinholeCamera& camera, const SparseMap& map, int* count) {
  double sq = 0.0;
  int n = 0;
  for (int t : ids) {
    for (size_t k = 0; k < tracks[t].obs.size(); ++k) {
      if (!map.obs_valid[t][k]) continue;
      const double e = ReprojectionErrorPx(map, camera, tracks[t].obs[k].keyframe,
                                           map.point_world[t], tracks[t].obs[k].px);
      sq += std::min(e * e, 1e4);
      ++n;
    }
  }
  if (count) *count = n;
  return n ? std::sqrt(sq / n) : 0.0;
}

// The keyframe poses, mount, shared focal scale and, where the map has them, the keyframes' own
// focal scales (over the starting focal length) in one buffer, in a fixed order. Ceres orders the
// blocks of an elimination group by address; separate allocations would let the heap's layout
// (which other threads touch) change the order, and with it the rounding, from run to run.
class CameraBlocks {
 public:
  explicit CameraBlocks(const SparseMap& map)
      : n_(static_cast<int>(map.centre_world.size())),
        per_keyframe_(!map.keyframe_focal_scale.empty()) {
    v_.resize(7 * n_ + 5 + (per_keyframe_ ? n_ : 0));
    for (int k = 0; k < n_; ++k) {
      std::copy_n(map.cam_from_world[k].coeffs().data(), 4, q(k));
      std::copy_n(map.centre_world[k].data(), 3, c(k));
      if (per_keyframe_) *keyframe_focal(k) = map.FocalScaleAt(k);
    }
    std::copy_n(map.arm_from_cam.coeffs().data(), 4, mount());
    *focal() = map.focal_scale;
  }
  double* pose(int k) { return &v_[7 * k]; }  // [q_cam_from_world, c_world]
  double* q(int k) { return &v_[7 * k]; }
  double* c(int k) { return &v_[7 * k + 4]; }
  double* mount() { return &v_[7 * n_]; }
  double* focal() { return &v_[7 * n_ + 4]; }
  bool per_keyframe() const { return per_keyframe_; }
  double* keyframe_focal(int k) { return &v_[7 * n_ + 5 + k]; }
  // The focal scale keyframe k's observations see.
  double* focal_of(int k) { return per_keyframe_ ? keyframe_focal(k) : focal(); }
  void CopyTo(SparseMap* map) {
    for (int k = 0; k < n_; ++k) {
      std::copy_n(q(k), 4, map->cam_from_world[k].coeffs().data());
      std::copy_n(c(k), 3, map->centre_world[k].data());
      if (per_keyframe_) map->keyframe_focal_scale[k] = *keyframe_focal(k) / *focal();
    }
    std::copy_n(mount(), 4, map->arm_from_cam.coeffs().data());
    map->focal_scale = *focal();
  }

 private:
  int n_;
  bool per_keyframe_;
  std::vector<double> v_;
};

}  // namespace

BundleSummary RunBundleAdjustment(const BundleOptions& o, const std::vector<Track>& tracks,
                                  const PinholeCamera& camera, SparseMap* map) {
  o.Check();
  BundleSummary s;
  const std::vector<int> ids = SelectPoints(o, tracks, *map);
  s.initial_rms_px = RmsPx(tracks, ids, camera, *map, nullptr);

  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>> pose_manifold;
  const int n_kf = static_cast<int>(map->centre_world.size());
  CameraBlocks cams(*map);
  ceres::LossFunction* reprojection_loss = new ceres::HuberLoss(o.loss_px);
  ceres::LossFunction* prior_loss = new ceres::HuberLoss(3.0);
  std::vector<char> kf_used(n_kf, 0);
  const RadialLens lens{camera.k1, camera.k2, camera.k3};
  for (int t : ids) {
    for (size_t k = 0; k < tracks[t].obs.size(); ++k) {
      if (!map->obs_valid[t][k]) continue;
      const Observation& ob = tracks[t].obs[k];
      const Eigen::Vector3d ray = camera.CamRayFromImage(ob.px);
      if (RadialScaleAt(lens, ray.head<2>().squaredNorm()) < o.min_lens_scale) continue;
      problem.AddResidualBlock(PoseReprojectionCost::Create(ray.head<2>(), camera.fx, lens),
                               reprojection_loss, cams.pose(ob.keyframe),
                               map->point_world[t].data(), cams.focal_of(ob.keyframe));
      kf_used[ob.keyframe] = 1;
      ++s.observations;
    }
    ++s.points;
  }
  for (int k = 0; k < n_kf; ++k) {
    double* pose = cams.pose(k);
    problem.AddResidualBlock(
        PoseCirclePriorError::Create(o.arm_radius_m, o.sigma_radius_m, o.sigma_height_m),
        prior_loss, pose);
    problem.AddResidualBlock(PoseMountPriorError::Create(o.sigma_mount_deg * M_PI / 180.0),
                             prior_loss, pose, cams.mount());
    problem.SetManifold(pose, &pose_manifold);
  }
  problem.SetManifold(cams.mount(), &quaternion_manifold);
  if (cams.per_keyframe()) {
    for (int k = 0; k < n_kf; ++k) {
      if (!kf_used[k]) continue;
      problem.AddResidualBlock(KeyframeFocalPriorError::Create(o.sigma_keyframe_focal_pct / 100.0),
                               nullptr, cams.keyframe_focal(k), cams.focal());
    }
  }
  if (!o.refine_focal && problem.HasParameterBlock(cams.focal())) {
    problem.SetParameterBlockConstant(cams.focal());
  }
  problem.AddResidualBlock(PoseYawGaugeError::Create(), nullptr, cams.pose(0));

  ceres::Solver::Options so;
  // Points first, everything else after: left to itself Ceres also eliminates the mount (it
  // touches no point), whose 3-row priors then keep the Schur eliminator off its fixed-size
  // (2 rows, 3-point, 3-camera) specialisation.
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  std::vector<double*> blocks;
  problem.GetParameterBlocks(&blocks);
  for (double* b : blocks) ordering->AddElementToGroup(b, 1);
  for (int t : ids) {
    double* point = map->point_world[t].data();
    if (problem.HasParameterBlock(point)) ordering->AddElementToGroup(point, 0);
  }
  so.linear_solver_ordering = ordering;
  // The reduced camera system couples most keyframes (each sees a sixth of the turn, the loop ties
  // the ends), so a dense factorisation beats the sparse one until it gets large.
  so.linear_solver_type =
      n_kf <= o.dense_schur_max_keyframes ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  so.num_threads = o.threads;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = o.function_tolerance;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  cams.CopyTo(map);
  s.iterations = static_cast<int>(summary.iterations.size());
  s.converged = summary.termination_type == ceres::CONVERGENCE;
  spdlog::debug("bundle adjustment: {}", summary.BriefReport());

  // Drop what the solution cannot explain: single observations, and tracks that move.
  std::vector<double> errors_px;
  for (int t : ids) {
    int good = 0;
    double good_sq_px = 0.0;
    for (size_t k = 0; k < tracks[t].obs.size(); ++k) {
      if (!map->obs_valid[t][k]) continue;
      const double e = ReprojectionErrorPx(*map, camera, tracks[t].obs[k].keyframe,
                                           map->point_world[t], tracks[t].obs[k].px);
      errors_px.push_back(e);
      if (e > o.outlier_px) {
        map->obs_valid[t][k] = 0;
        ++s.rejected_observations;
      } else {
        ++good;
        good_sq_px += e * e;
      }
    }
    const bool moves = o.max_track_rms_px > 0.0 && good > 0 &&
                       good_sq_px > good * o.max_track_rms_px * o.max_track_rms_px;
    if (moves) {
      // Its observations go too, so that no later round triangulates it again.
      std::fill(map->obs_valid[t].begin(), map->obs_valid[t].end(), 0);
      ++s.rejected_points;
    }
    if (good < 2 || moves) map->point_valid[t] = 0;
  }
  s.final_rms_px = RmsPx(tracks, ids, camera, *map, nullptr);
  if (!errors_px.empty()) {
    std::sort(errors_px.begin(), errors_px.end());
    const auto at = [&](double q) {
      return errors_px[static_cast<size_t>(q * static_cast<double>(errors_px.size() - 1))];
    };
    spdlog::debug(
        "bundle adjustment: error percentiles 50/75/90/99: {:.2f} {:.2f} {:.2f} {:.2f} px", at(0.5),
        at(0.75), at(0.9), at(0.99));
  }
  return s;
}

}  // namespace stemmap::track
