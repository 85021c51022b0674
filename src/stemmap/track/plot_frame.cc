#include "stemmap/track/plot_frame.h"

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"

namespace stemmap::track {

void GroundFitOptions::Check() const {
  if (!(min_range_m >= 0 && max_range_m > min_range_m + 1)) {
    throw InputError("the ground's range must be a band at least 1 m wide from 0 m out");
  }
  if (!(cell_m >= 0.1 && cell_m <= 5)) throw InputError("the ground cell must lie in [0.1, 5] m");
  if (!(inlier_m > 0 && inlier_m < 1)) throw InputError("the ground band must lie in (0, 1) m");
  if (!(max_tilt_deg > 0 && max_tilt_deg < 60)) {
    throw InputError("the ground's greatest tilt must lie in (0, 60)°");
  }
  if (min_cells < 3) throw InputError("the ground needs at least 3 cells");
}

namespace {

// A plane z = a x + b y + c as (a, b, c).
double PlaneZ(const Eigen::Vector3d& plane, const Eigen::Vector3d& p) {
  return plane.x() * p.x() + plane.y() * p.y() + plane.z();
}

using CellKey = std::pair<int, int>;

CellKey CellOf(const GroundFitOptions& o, const Eigen::Vector3d& p) {
  return {static_cast<int>(std::floor(p.x() / o.cell_m)),
          static_cast<int>(std::floor(p.y() / o.cell_m))};
}

// The floor of each cell: its points' 10th-percentile height (the lowest of fewer than 10; the
// odd point below the ground does not set it), at the cell's points' mean x and y.
std::map<CellKey, Eigen::Vector3d> CellFloors(const GroundFitOptions& o,
                                              const std::vector<Eigen::Vector3d>& pts) {
  std::map<CellKey, std::vector<Eigen::Vector3d>> cells;
  for (const Eigen::Vector3d& p : pts) cells[CellOf(o, p)].push_back(p);
  std::map<CellKey, Eigen::Vector3d> floors;
  for (auto& [key, v] : cells) {
    const size_t q = v.size() / 10;
    std::nth_element(
        v.begin(), v.begin() + q, v.end(),
        [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.z() < b.z(); });
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const Eigen::Vector3d& p : v) mean += p.head<2>();
    mean /= static_cast<double>(v.size());
    floors[key] = Eigen::Vector3d(mean.x(), mean.y(), v[q].z());
  }
  return floors;
}

// A cell's floor lies on the ground to within the slope across the cell.
double FloorBand(const GroundFitOptions& o) {
  return o.inlier_m + 0.5 * o.cell_m * std::tan(o.max_tilt_deg * M_PI / 180.0);
}

// Of the planes through three floors within the tilt, the one most floors lie on, less three
// times the floors clearly below it (the ground has nothing under it but the odd stray point).
// Returns false when none is supported by min_cells floors.
bool FloorPlane(const GroundFitOptions& o, const std::vector<Eigen::Vector3d>& floors,
                Eigen::Vector3d* plane) {
  const int n = static_cast<int>(floors.size());
  const double max_gradient = std::tan(o.max_tilt_deg * M_PI / 180.0);
  const double band = FloorBand(o);
  Rng rng(o.seed);
  int best_score = std::numeric_limits<int>::min(), best_support = 0;
  for (int it = 0; it < 2000; ++it) {
    const Eigen::Vector3d &a = floors[rng.UniformInt(0, n - 1)],
                          &b = floors[rng.UniformInt(0, n - 1)],
                          &c = floors[rng.UniformInt(0, n - 1)];
    Eigen::Matrix3d m;
    m << a.x(), a.y(), 1, b.x(), b.y(), 1, c.x(), c.y(), 1;
    if (std::abs(m.determinant()) < 1e-3) continue;
    const Eigen::Vector3d p = m.inverse() * Eigen::Vector3d(a.z(), b.z(), c.z());
    if (p.head<2>().norm() > max_gradient) continue;
    int on = 0, below = 0;
    for (const Eigen::Vector3d& f : floors) {
      const double e = f.z() - PlaneZ(p, f);
      on += std::abs(e) < band;
      below += e < -2 * o.inlier_m;
    }
    if (on - 3 * below > best_score) {
      best_score = on - 3 * below;
      best_support = on;
      *plane = p;
    }
  }
  if (best_support < o.min_cells) return false;
  // Reweighted least squares on the floors: those above the plane (leaves with no gap to the
  // ground under them) count little or not at all, and those far below it (stray points) less.
  for (int it = 0; it < 10; ++it) {
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
    Eigen::Vector3d atb = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& f : floors) {
      const double e = f.z() - PlaneZ(*plane, f);
      // Above: Tukey's weight, none beyond twice the band (a long tail would lift the plane
      // onto the low shrubs); far below: Huber's.
      const double above = 2 * o.inlier_m;
      const double w = e > 0 ? (e < above ? std::pow(1 - (e / above) * (e / above), 2) : 0.0)
                             : (e < -3 * band ? 3 * band / -e : 1.0);
      const Eigen::Vector3d row(f.x(), f.y(), 1.0);
      ata += w * row * row.transpose();
      atb += w * row * f.z();
    }
    *plane = ata.ldlt().solve(atb);
  }
  return true;
}

}  // namespace

GroundFit FitGround(const GroundFitOptions& o, const std::vector<Eigen::Vector3d>& pts_all) {
  GroundFit g;
  std::vector<Eigen::Vector3d> pts;
  for (const Eigen::Vector3d& p : pts_all) {
    const double r = p.head<2>().norm();
    if (r >= o.min_range_m && r <= o.max_range_m && p.z() < -0.5) pts.push_back(p);
  }
  const std::map<CellKey, Eigen::Vector3d> cell_floors = CellFloors(o, pts);
  std::vector<Eigen::Vector3d> floors;
  for (const auto& [key, f] : cell_floors) floors.push_back(f);
  if (static_cast<int>(floors.size()) < o.min_cells) return g;
  Eigen::Vector3d plane;
  if (!FloorPlane(o, floors, &plane)) return g;
  // Least squares on the points near the plane in the cells whose floor is on it (the floors sit
  // at the cells' low ends; other cells' points near the plane are low leaves, which would lift
  // it): the plane through their centroid along their smallest axis.
  std::vector<Eigen::Vector3d> ground_cell_pts;
  for (const Eigen::Vector3d& p : pts) {
    const Eigen::Vector3d& f = cell_floors.at(CellOf(o, p));
    if (std::abs(f.z() - PlaneZ(plane, f)) < FloorBand(o)) ground_cell_pts.push_back(p);
  }
  Eigen::Vector3d normal = Eigen::Vector3d(-plane.x(), -plane.y(), 1.0).normalized();
  double offset = -normal.z() * plane.z();  // normal . p + offset = 0
  for (int refine = 0; refine < 3; ++refine) {
    std::vector<Eigen::Vector3d> in;
    for (const Eigen::Vector3d& p : ground_cell_pts) {
      if (std::abs(normal.dot(p) + offset) < o.inlier_m) in.push_back(p);
    }
    if (static_cast<int>(in.size()) < 3) break;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const Eigen::Vector3d& p : in) mean += p;
    mean /= static_cast<double>(in.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const Eigen::Vector3d& p : in) cov += (p - mean) * (p - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    Eigen::Vector3d nn = es.eigenvectors().col(0);
    if (nn.z() < 0) nn = -nn;
    if (nn.z() < std::cos(o.max_tilt_deg * M_PI / 180.0)) break;  // a sliver, not the ground
    normal = nn;
    offset = -nn.dot(mean);
    g.inliers = static_cast<int>(in.size());
  }
  g.found = true;
  g.normal = normal;
  g.height_at_axis_m = -offset / normal.z();
  g.slope_deg = std::acos(std::clamp(normal.z(), -1.0, 1.0)) * 180.0 / M_PI;
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
