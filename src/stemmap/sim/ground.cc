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
  inv_table_step_ = 1.0 / table_step_m_;
  table_n_ = static_cast<int>(std::ceil(2.0 * extent_m / table_step_m_)) + 2;
  const size_t n = static_cast<size_t>(table_n_);
  bump_m_.resize(n * n);
  slope_.resize(n * n);
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) {
      const double x = table_origin_m_ + j * table_step_m_, y = table_origin_m_ + i * table_step_m_;
      bump_m_[i * n + j] = static_cast<float>(BumpFromNoise(x, y));
    }
  }
  // Node slopes by central differences (one-sided at the border).
  auto bump = [&](size_t i, size_t j) { return static_cast<double>(bump_m_[i * n + j]); };
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) {
      const size_t j0 = j > 0 ? j - 1 : j, j1 = j + 1 < n ? j + 1 : j;
      const size_t i0 = i > 0 ? i - 1 : i, i1 = i + 1 < n ? i + 1 : i;
      slope_[i * n + j].dx =
          static_cast<float>((bump(i, j1) - bump(i, j0)) / ((j1 - j0) * table_step_m_));
      slope_[i * n + j].dy =
          static_cast<float>((bump(i1, j) - bump(i0, j)) / ((i1 - i0) * table_step_m_));
    }
  }
  const double s = std::tan(slope_deg * std::numbers::pi / 180.0);
  // Height falls toward the downhill azimuth.
  plane_gradient_ =
      -s * Eigen::Vector2d(std::cos(downhill_azimuth_rad), std::sin(downhill_azimuth_rad));
  // The tabulated surface is piecewise bilinear: its steepest slope is found among the cells.
  double max_bump_slope = 0.0;
  for (size_t i = 0; i + 1 < n; ++i) {
    for (size_t j = 0; j + 1 < n; ++j) {
      const double gx = std::max(std::abs(bump(i, j + 1) - bump(i, j)),
                                 std::abs(bump(i + 1, j + 1) - bump(i + 1, j)));
      const double gy = std::max(std::abs(bump(i + 1, j) - bump(i, j)),
                                 std::abs(bump(i + 1, j + 1) - bump(i, j + 1)));
      max_bump_slope = std::max(max_bump_slope, std::hypot(gx, gy) / table_step_m_);
    }
  }
  offset_m_ = Raw(0.0, 0.0);
  // The renderer never marches beyond the table (it stops at the distant-forest wall).
  bump_lipschitz_ = std::max(1.1 * max_bump_slope, 1e-4);
  lipschitz_ = s + bump_lipschitz_;
}

double Ground::BumpFromNoise(double x, double y) const {
  return unevenness_m_ * noise_.Fbm2(x / wavelength_m_, y / wavelength_m_, kOctaves);
}

double Ground::Raw(double x, double y) const { return Height(x, y) + offset_m_; }

Eigen::Vector2d Ground::Gradient(double x, double y) const {
  size_t node;
  double wx, wy;
  if (!Cell(x, y, &node, &wx, &wy)) {
    const double h = 0.5 * table_step_m_;
    return {(Raw(x + h, y) - Raw(x - h, y)) / (2 * h), (Raw(x, y + h) - Raw(x, y - h)) / (2 * h)};
  }
  const Slope* n0 = &slope_[node];
  const Slope* n1 = n0 + table_n_;
  const double w00 = (1 - wx) * (1 - wy), w01 = wx * (1 - wy), w10 = (1 - wx) * wy, w11 = wx * wy;
  return plane_gradient_ +
         Eigen::Vector2d(w00 * n0[0].dx + w01 * n0[1].dx + w10 * n1[0].dx + w11 * n1[1].dx,
                         w00 * n0[0].dy + w01 * n0[1].dy + w10 * n1[0].dy + w11 * n1[1].dy);
}

Eigen::Vector3d Ground::Normal(double x, double y) const {
  const Eigen::Vector2d g = Gradient(x, y);
  return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

}  // namespace stemmap::sim
