#include "stemmap/sim/ground.h"

#include <cmath>
#include <numbers>

namespace stemmap::sim {

namespace {
constexpr int kOctaves = 3;
}  // namespace

Ground::Ground(double slope_deg, double downhill_azimuth_rad, double unevenness_m,
               double wavelength_m, uint64_t seed, double extent_m)
    : unevenness_m_(unevenness_m),
      wavelength_m_(wavelength_m),
      slope_deg_(slope_deg),
      noise_(seed) {
  table_origin_m_ = -extent_m;
  table_n_ = static_cast<int>(std::ceil(2.0 * extent_m / table_step_m_)) + 2;
  bump_table_.resize(static_cast<size_t>(table_n_) * table_n_);
  for (int i = 0; i < table_n_; ++i) {
    for (int j = 0; j < table_n_; ++j) {
      const double x = table_origin_m_ + j * table_step_m_, y = table_origin_m_ + i * table_step_m_;
      bump_table_[static_cast<size_t>(i) * table_n_ + j] = static_cast<float>(
          unevenness_m_ * noise_.Fbm2(x / wavelength_m_, y / wavelength_m_, kOctaves));
    }
  }
  const double s = std::tan(slope_deg * std::numbers::pi / 180.0);
  // Height falls toward the downhill azimuth.
  plane_gradient_ =
      -s * Eigen::Vector2d(std::cos(downhill_azimuth_rad), std::sin(downhill_azimuth_rad));
  // The tabulated surface is piecewise bilinear: its steepest slope is found among the cells.
  double max_bump_slope = 0.0;
  for (int i = 0; i + 1 < table_n_; ++i) {
    for (int j = 0; j + 1 < table_n_; ++j) {
      const float* r0 = &bump_table_[static_cast<size_t>(i) * table_n_ + j];
      const float* r1 = r0 + table_n_;
      const double gx = std::max(std::abs(r0[1] - r0[0]), std::abs(r1[1] - r1[0]));
      const double gy = std::max(std::abs(r1[0] - r0[0]), std::abs(r1[1] - r0[1]));
      max_bump_slope = std::max(max_bump_slope, std::hypot(gx, gy) / table_step_m_);
    }
  }
  offset_m_ = Raw(0.0, 0.0);
  // The renderer never marches beyond the table (it stops at the distant-forest wall).
  lipschitz_ = s + std::max(1.1 * max_bump_slope, 1e-4);
}

double Ground::Bump(double x, double y) const {
  const double fx = (x - table_origin_m_) / table_step_m_,
               fy = (y - table_origin_m_) / table_step_m_;
  const int j = static_cast<int>(std::floor(fx)), i = static_cast<int>(std::floor(fy));
  if (i < 0 || j < 0 || i + 1 >= table_n_ || j + 1 >= table_n_) {
    return unevenness_m_ * noise_.Fbm2(x / wavelength_m_, y / wavelength_m_, kOctaves);
  }
  const double wx = fx - j, wy = fy - i;
  const float* r0 = &bump_table_[static_cast<size_t>(i) * table_n_ + j];
  const float* r1 = r0 + table_n_;
  return (1 - wy) * ((1 - wx) * r0[0] + wx * r0[1]) + wy * ((1 - wx) * r1[0] + wx * r1[1]);
}

double Ground::Raw(double x, double y) const {
  return plane_gradient_.x() * x + plane_gradient_.y() * y + Bump(x, y);
}

double Ground::Height(double x, double y) const { return Raw(x, y) - offset_m_; }

Eigen::Vector2d Ground::Gradient(double x, double y) const {
  const double h = 0.5 * table_step_m_;
  return {(Raw(x + h, y) - Raw(x - h, y)) / (2 * h), (Raw(x, y + h) - Raw(x, y - h)) / (2 * h)};
}

Eigen::Vector3d Ground::Normal(double x, double y) const {
  const Eigen::Vector2d g = Gradient(x, y);
  return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

}  // namespace stemmap::sim
