#include "stemmap/track/plot_frame.h"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "stemmap/core/rng.h"

namespace stemmap::track {

GroundFit FitGround(const std::vector<Eigen::Vector3d>& pts_all, double min_range_m,
                    double max_range_m, double inlier_m, uint64_t seed) {
  GroundFit g;
  std::vector<Eigen::Vector3d> pts;
  for (const Eigen::Vector3d& p : pts_all) {
    const double r = p.head<2>().norm();
    if (r >= min_range_m && r <= max_range_m && p.z() < -0.5) pts.push_back(p);
  }
  const int n = static_cast<int>(pts.size());
  if (n < 20) return g;
  const double max_tilt_cos = std::cos(20.0 * M_PI / 180.0);
  Rng rng(seed);
  Eigen::Vector3d best_n = Eigen::Vector3d::UnitZ();
  double best_d = 0.0;
  int best_count = 0;
  for (int it = 0; it < 400; ++it) {
    const Eigen::Vector3d &a = pts[rng.UniformInt(0, n - 1)], &b = pts[rng.UniformInt(0, n - 1)],
                          &c = pts[rng.UniformInt(0, n - 1)];
    Eigen::Vector3d nn = (b - a).cross(c - a);
    if (nn.norm() < 1e-6) continue;
    nn.normalize();
    if (nn.z() < 0) nn = -nn;
    if (nn.z() < max_tilt_cos) continue;
    const double d = -nn.dot(a);
    int count = 0;
    for (const Eigen::Vector3d& p : pts) count += std::abs(nn.dot(p) + d) < inlier_m;
    // Ties go to the lower plane: shrubs and stem bases sit above the ground, never below.
    if (count > best_count || (count == best_count && d > best_d)) {
      best_count = count;
      best_n = nn;
      best_d = d;
    }
  }
  if (best_count < std::max(15, n / 10)) return g;
  // Least squares on the inliers: the plane through their centroid along the smallest axis.
  for (int refine = 0; refine < 2; ++refine) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> in;
    for (const Eigen::Vector3d& p : pts) {
      if (std::abs(best_n.dot(p) + best_d) < inlier_m) in.push_back(p);
    }
    for (const Eigen::Vector3d& p : in) mean += p;
    mean /= static_cast<double>(in.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const Eigen::Vector3d& p : in) cov += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    Eigen::Vector3d nn = es.eigenvectors().col(0);
    if (nn.z() < 0) nn = -nn;
    best_n = nn;
    best_d = -nn.dot(mean);
    g.inliers = static_cast<int>(in.size());
  }
  g.found = true;
  g.normal = best_n;
  g.height_at_axis_m = -best_d / best_n.z();
  g.slope_deg = std::acos(std::clamp(best_n.z(), -1.0, 1.0)) * 180.0 / M_PI;
  return g;
}

Rigid3d PlotFromAxis(const Eigen::Vector3d& up_axis, double ground_height_at_axis_m,
                     const Eigen::Vector3d& forward_axis) {
  const Eigen::Vector3d z = up_axis.normalized();
  Eigen::Vector3d x = forward_axis - forward_axis.dot(z) * z;
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d plot_from_axis_rot;
  plot_from_axis_rot.row(0) = x.transpose();
  plot_from_axis_rot.row(1) = y.transpose();
  plot_from_axis_rot.row(2) = z.transpose();
  Rigid3d t;
  t.rotation = Eigen::Quaterniond(plot_from_axis_rot);
  // The ground point on the axis (axis-frame z, moved along the axis) becomes the origin.
  const Eigen::Vector3d origin_axis(0.0, 0.0, ground_height_at_axis_m);
  t.translation = -(t.rotation * origin_axis);
  return t;
}

}  // namespace stemmap::track
