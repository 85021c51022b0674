#include "stemmap/track/vertical.h"

#include <spdlog/spdlog.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>

#include "stemmap/core/error.h"

namespace stemmap::track {

void VerticalOptions::Check() const {
  if (!(inlier_deg > 0) || !(max_from_axis_deg > 0)) {
    throw InputError("vertical estimation thresholds must be positive");
  }
  if (!(cell_m > 0) || !(ray_tolerance_m > 0) || !(max_range_m > min_range_m)) {
    throw InputError("vertical estimation: trunk grouping sizes must be positive");
  }
}

std::vector<int> GroupRaysByTrunk(const VerticalOptions& o,
                                  const std::vector<Eigen::Vector2d>& origins,
                                  const std::vector<Eigen::Vector2d>& directions,
                                  const std::vector<int>& views) {
  const int n_rays = static_cast<int>(origins.size());
  const double extent = o.max_range_m + 2.0;  // cameras sit within a metre or so of the axis
  const int side = static_cast<int>(std::ceil(2 * extent / o.cell_m));
  auto cell_of = [&](const Eigen::Vector2d& p) {
    const int i = static_cast<int>(std::floor((p.x() + extent) / o.cell_m));
    const int j = static_cast<int>(std::floor((p.y() + extent) / o.cell_m));
    return (i < 0 || j < 0 || i >= side || j >= side) ? -1 : j * side + i;
  };
  std::vector<std::vector<int>> crossed(n_rays);
  for (int r = 0; r < n_rays; ++r) {
    for (double t = o.min_range_m; t <= o.max_range_m; t += 0.5 * o.cell_m) {
      const int c = cell_of(origins[r] + t * directions[r]);
      if (c >= 0 && (crossed[r].empty() || crossed[r].back() != c)) crossed[r].push_back(c);
    }
    std::ranges::sort(crossed[r]);
    // (std::unique, not ranges::unique: clang 14, which builds the fuzz targets, cannot compile
    // the latter's subrange with GCC 12's library.)
    crossed[r].erase(std::unique(crossed[r].begin(), crossed[r].end()), crossed[r].end());
  }
  // A cell gets one vote from each view with a ray through it: all of a view's rays meet at its
  // camera, so counting rays would make trunks of the cells just in front of every camera. Per
  // view, the cells its rays cross (sorted) and how many of its rays cross each.
  std::map<int, std::vector<std::pair<int, int>>> rays_in_cell;  // view -> (cell, rays)
  {
    std::map<int, std::vector<int>> cells_of_view;
    for (int r = 0; r < n_rays; ++r) {
      std::vector<int>& cells = cells_of_view[views[r]];
      cells.insert(cells.end(), crossed[r].begin(), crossed[r].end());
    }
    for (auto& [view, cells] : cells_of_view) {
      std::ranges::sort(cells);
      std::vector<std::pair<int, int>>& counted = rays_in_cell[view];
      for (int c : cells) {
        if (counted.empty() || counted.back().first != c) counted.emplace_back(c, 0);
        ++counted.back().second;
      }
    }
  }
  std::vector<int> votes(static_cast<size_t>(side) * side, 0);
  for (const auto& [view, counted] : rays_in_cell) {
    for (const auto& [c, rays] : counted) ++votes[c];
  }
  // Greedy: the best-voted cell is a trunk; its rays leave the vote.
  std::vector<int> group(n_rays, -1);
  int groups = 0;
  while (true) {
    const auto best = std::ranges::max_element(votes);  // first of equals: deterministic
    if (*best < o.min_trunk_segments) break;
    const int c = static_cast<int>(best - votes.begin());
    const Eigen::Vector2d centre((c % side + 0.5) * o.cell_m - extent,
                                 (c / side + 0.5) * o.cell_m - extent);
    int members = 0;
    for (int r = 0; r < n_rays; ++r) {
      if (group[r] >= 0) continue;
      const Eigen::Vector2d q = centre - origins[r];
      const double along = q.dot(directions[r]);
      const double across = std::abs(q.x() * directions[r].y() - q.y() * directions[r].x());
      if (along < o.min_range_m - o.cell_m || across > o.ray_tolerance_m) continue;
      group[r] = groups;
      ++members;
      std::vector<std::pair<int, int>>& counted = rays_in_cell[views[r]];
      for (int k : crossed[r]) {
        auto it = std::ranges::lower_bound(counted, std::make_pair(k, 0));
        if (--it->second == 0) --votes[k];
      }
    }
    if (members == 0) {
      votes[c] = 0;  // its voters passed too far from the cell's centre
      continue;
    }
    spdlog::trace("vertical: trunk {} at ({:.2f}, {:.2f}), {} segments", groups, centre.x(),
                  centre.y(), members);
    ++groups;
  }
  for (int& g : group) {
    if (g < 0) g = groups++;
  }
  return group;
}

VerticalEstimate EstimateVertical(const VerticalOptions& o, const std::vector<Keyframe>& keyframes,
                                  const SparseMap& map, const PinholeCamera& camera) {
  o.Check();
  VerticalEstimate v;
  // Unit normals (axis frame) of the planes through each camera centre and trunk edge: a
  // vertical edge's plane contains "up", so n . up = 0. Each segment's horizontal viewing ray
  // says where along the plane its trunk stands.
  std::vector<Eigen::Vector3d> normals;
  std::vector<Eigen::Vector2d> origins, directions;
  std::vector<int> views;
  for (size_t k = 0; k < keyframes.size() && k < map.cam_from_world.size(); ++k) {
    const Eigen::Quaterniond world_from_cam = map.cam_from_world[k].conjugate();
    for (const cv::Vec4f& s : keyframes[k].vertical_segments) {
      const Eigen::Vector3d a = camera.CamRayFromImage({s[0], s[1]});
      const Eigen::Vector3d b = camera.CamRayFromImage({s[2], s[3]});
      const Eigen::Vector3d n = world_from_cam * a.cross(b);
      const Eigen::Vector2d d = (world_from_cam * (a + b)).head<2>();
      if (n.norm() < 1e-9 || d.norm() < 1e-9) continue;
      normals.push_back(n.normalized());
      origins.push_back(map.centre_world[k].head<2>());
      directions.push_back(d.normalized());
      views.push_back(static_cast<int>(k));
      // One line per segment, for checking the grouping and the estimate offline.
      spdlog::trace(
          "vertical segment: view {} n {:.6f} {:.6f} {:.6f} origin {:.4f} {:.4f} dir {:.6f} {:.6f}",
          k, normals.back().x(), normals.back().y(), normals.back().z(), origins.back().x(),
          origins.back().y(), directions.back().x(), directions.back().y());
    }
  }
  // Each trunk's segments share one unit of weight.
  const std::vector<int> trunk = GroupRaysByTrunk(o, origins, directions, views);
  std::map<int, int> per_trunk;
  for (int t : trunk) ++per_trunk[t];
  std::vector<double> weight(normals.size());
  for (size_t i = 0; i < weight.size(); ++i) weight[i] = 1.0 / per_trunk[trunk[i]];
  v.trunks = static_cast<int>(per_trunk.size());
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
      const double w = weight[i] * std::pow(1.0 - r * r / 9.0, 2);
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
