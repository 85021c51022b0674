#include "stemmap/track/vertical.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <map>

#include "stemmap/core/error.h"

namespace stemmap::track {

void VerticalOptions::Check() const {
  if (!(inlier_deg > 0) || !(max_from_axis_deg > 0)) {
    throw InputError("vertical estimation thresholds must be positive");
  }
}

namespace {

// Median horizontal position of the points whose observations in keyframe `k` lie on the
// segment; false when none does.
bool LocateSegment(const VerticalOptions& o, const cv::Vec4f& s,
                   const std::vector<std::pair<Eigen::Vector2d, int>>& obs, const SparseMap& map,
                   Eigen::Vector2d* xy) {
  const Eigen::Vector2d a(s[0], s[1]), b(s[2], s[3]);
  const Eigen::Vector2d d = (b - a).normalized();
  const double len = (b - a).norm();
  std::vector<double> xs, ys;
  for (const auto& [px, t] : obs) {
    const Eigen::Vector2d q = px - a;
    const double along = q.dot(d);
    if (along < 0 || along > len || std::abs(q.x() * d.y() - q.y() * d.x()) > o.match_px) continue;
    xs.push_back(map.point_world[t].x());
    ys.push_back(map.point_world[t].y());
  }
  if (xs.size() < 2) return false;
  std::nth_element(xs.begin(), xs.begin() + xs.size() / 2, xs.end());
  std::nth_element(ys.begin(), ys.begin() + ys.size() / 2, ys.end());
  *xy = {xs[xs.size() / 2], ys[ys.size() / 2]};
  return true;
}

}  // namespace

VerticalEstimate EstimateVertical(const VerticalOptions& o, const std::vector<Keyframe>& keyframes,
                                  const std::vector<Track>& tracks, const SparseMap& map,
                                  const PinholeCamera& camera) {
  o.Check();
  VerticalEstimate v;
  // Observations of triangulated points per keyframe, to locate segments.
  std::vector<std::vector<std::pair<Eigen::Vector2d, int>>> obs_by_kf(keyframes.size());
  for (size_t t = 0; t < tracks.size() && t < map.point_valid.size(); ++t) {
    if (!map.point_valid[t]) continue;
    for (const Observation& ob : tracks[t].obs) {
      if (ob.keyframe < static_cast<int>(obs_by_kf.size())) {
        obs_by_kf[ob.keyframe].emplace_back(ob.px, static_cast<int>(t));
      }
    }
  }
  std::map<std::pair<int, int>, double> cluster_length;  // trunk key -> total segment length
  std::vector<std::pair<int, int>> key;
  // Unit normals (axis frame) of the planes through each camera centre and trunk edge, weighted
  // by the segment's length: a vertical edge's plane contains "up", so n . up = 0.
  std::vector<Eigen::Vector3d> normals;
  std::vector<double> length;
  for (size_t k = 0; k < keyframes.size() && k < map.cam_from_world.size(); ++k) {
    const Eigen::Quaterniond world_from_cam = map.cam_from_world[k].conjugate();
    for (const cv::Vec4f& s : keyframes[k].vertical_segments) {
      const Eigen::Vector3d a = camera.CamRayFromImage({s[0], s[1]});
      const Eigen::Vector3d b = camera.CamRayFromImage({s[2], s[3]});
      Eigen::Vector3d n = world_from_cam * a.cross(b);
      if (n.norm() < 1e-9) continue;
      Eigen::Vector2d xy;
      std::pair<int, int> k_cell;
      if (LocateSegment(o, s, obs_by_kf[k], map, &xy)) {
        k_cell = {static_cast<int>(std::floor(xy.x() / o.cell_m)),
                  static_cast<int>(std::floor(xy.y() / o.cell_m))};
      } else {
        const Eigen::Vector3d mid = world_from_cam * (a + b);
        const double az = std::atan2(mid.y(), mid.x()) * 180.0 / M_PI;
        k_cell = {1 << 20, static_cast<int>(std::floor(az / o.far_bin_deg))};
      }
      normals.push_back(n.normalized());
      length.push_back(std::hypot(s[2] - s[0], s[3] - s[1]));
      key.push_back(k_cell);
      cluster_length[k_cell] += length.back();
    }
  }
  // Each trunk's segments share one unit of weight.
  for (size_t i = 0; i < length.size(); ++i) length[i] /= cluster_length[key[i]];
  v.trunks = static_cast<int>(cluster_length.size());
  v.segments = static_cast<int>(normals.size());
  if (v.segments < o.min_segments) return v;
  const double scale = std::sin(o.inlier_deg * M_PI / 180.0);
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  for (int it = 0; it < 10; ++it) {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    double wsum = 0.0;
    int inliers = 0;
    for (size_t i = 0; i < normals.size(); ++i) {
      const double r = normals[i].dot(up) / scale;
      if (std::abs(r) > 3.0) continue;  // Tukey: edges of leaning, broken or bent things
      const double w = length[i] * std::pow(1.0 - r * r / 9.0, 2);
      m += w * normals[i] * normals[i].transpose();
      wsum += w;
      ++inliers;
    }
    if (inliers < o.min_segments) return v;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(m);
    Eigen::Vector3d next = es.eigenvectors().col(0);
    if (next.z() < 0) next = -next;
    v.inliers = inliers;
    // Residual spread per segment over the number of segments; repeated views of one trunk are
    // not independent, so this understates the error by roughly the views per trunk.
    v.sd_deg = std::sqrt(es.eigenvalues()(0) / wsum / std::max(1, inliers)) * 180.0 / M_PI;
    up = next;
  }
  v.tilt_deg = std::acos(std::clamp(up.z(), -1.0, 1.0)) * 180.0 / M_PI;
  if (v.tilt_deg > o.max_from_axis_deg) return v;
  v.found = true;
  v.up_axis = up;
  return v;
}

}  // namespace stemmap::track
