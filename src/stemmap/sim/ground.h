#pragma once

#include <Eigen/Core>
#include <vector>

#include "stemmap/core/noise.h"

namespace stemmap::sim {

// Ground heightfield z = g(x, y): a tilted plane plus smooth unevenness, shifted so g(0, 0) = 0
// (the plot origin is on the rotation axis at ground level).
class Ground {
 public:
  Ground() = default;
  // slope_deg: steepest slope of the plane, toward `downhill_azimuth_rad`.
  // unevenness_m: amplitude of the bumps; wavelength_m: their size.
  Ground(double slope_deg, double downhill_azimuth_rad, double unevenness_m, double wavelength_m,
         uint64_t seed, double extent_m = 60.0);

  inline double Height(double x, double y) const;
  // Gradient of the height (its own slope per metre in x and y), smooth across table cells.
  Eigen::Vector2d Gradient(double x, double y) const;
  Eigen::Vector3d Normal(double x, double y) const;
  // Upper bound of |∇g| over the whole field; the renderer's ray march relies on it.
  double LipschitzBound() const { return lipschitz_; }
  // The same for the bumps alone, without the plane's slope.
  double BumpLipschitzBound() const { return bump_lipschitz_; }
  double slope_deg() const { return slope_deg_; }
  // The field lies within ±BumpBound() of the plane PlaneHeight().
  double PlaneHeight(double x, double y) const {
    return plane_gradient_.x() * x + plane_gradient_.y() * y - offset_m_;
  }
  double BumpBound() const { return unevenness_m_ * 1.001 + 1e-6; }
  const Eigen::Vector2d& plane_gradient() const { return plane_gradient_; }

 private:
  double Raw(double x, double y) const;
  double BumpFromNoise(double x, double y) const;
  // The unevenness is tabulated (bilinear, fine enough that it matches the noise to < 1 mm),
  // since the renderer evaluates it millions of times per frame; apart, its slope at each node
  // (central differences), read the same way for shading normals that do not show the cells.
  // Apart, so that the ray march reads a table a third the size.
  struct Slope {
    float dx, dy;
  };
  // The cell holding (x, y), as the index of its first node, and the weights within it; false
  // outside the table.
  inline bool Cell(double x, double y, size_t* node, double* wx, double* wy) const;
  std::vector<float> bump_m_;
  std::vector<Slope> slope_;
  int table_n_ = 0;
  double table_step_m_ = 0.1, inv_table_step_ = 10.0, table_origin_m_ = 0.0;
  Eigen::Vector2d plane_gradient_ = Eigen::Vector2d::Zero();
  double unevenness_m_ = 0.0;
  double wavelength_m_ = 1.0;
  double offset_m_ = 0.0;
  double lipschitz_ = 0.0, bump_lipschitz_ = 0.0;
  double slope_deg_ = 0.0;
  ValueNoise noise_;
};

// Per ray-march step: inline, with the cell found by products rather than divisions.
bool Ground::Cell(double x, double y, size_t* node, double* wx, double* wy) const {
  const double fx = (x - table_origin_m_) * inv_table_step_,
               fy = (y - table_origin_m_) * inv_table_step_;
  if (!(fx >= 0.0 && fy >= 0.0 && fx < table_n_ - 1 && fy < table_n_ - 1)) return false;
  const int j = static_cast<int>(fx), i = static_cast<int>(fy);
  *wx = fx - j;
  *wy = fy - i;
  *node = static_cast<size_t>(i) * table_n_ + j;
  return true;
}

double Ground::Height(double x, double y) const {
  const double plane = plane_gradient_.x() * x + plane_gradient_.y() * y - offset_m_;
  size_t node;
  double wx, wy;
  if (!Cell(x, y, &node, &wx, &wy)) return plane + BumpFromNoise(x, y);
  const float* r0 = &bump_m_[node];
  const float* r1 = r0 + table_n_;
  return plane + (1 - wy) * ((1 - wx) * r0[0] + wx * r0[1]) + wy * ((1 - wx) * r1[0] + wx * r1[1]);
}

}  // namespace stemmap::sim
