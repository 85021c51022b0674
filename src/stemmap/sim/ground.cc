#include "stemmap/sim/ground.h"

#include <cmath>
#include <numbers>

namespace stemmap::sim {

namespace {
constexpr int kOctaves = 3;
// Largest slope of quintic value noise on [-1, 1] per lattice unit is 1.875 * 2.
constexpr double kNoiseSlopePerUnit = 3.75;
}  // namespace

Ground::Ground(double slope_deg, double downhill_azimuth_rad, double unevenness_m,
               double wavelength_m, uint64_t seed)
    : unevenness_m_(unevenness_m), wavelength_m_(wavelength_m), slope_deg_(slope_deg),
      noise_(seed) {
  const double s = std::tan(slope_deg * std::numbers::pi / 180.0);
  // Height falls toward the downhill azimuth.
  plane_gradient_ = -s * Eigen::Vector2d(std::cos(downhill_azimuth_rad),
                                         std::sin(downhill_azimuth_rad));
  offset_m_ = Raw(0.0, 0.0);
  // Fbm normalises by sum of amplitudes (1 + 0.5 + 0.25) while octave k has slope 2^k times.
  const double fbm_slope = kNoiseSlopePerUnit * (1.0 + 1.0 + 1.0) / 1.75;
  lipschitz_ = s + unevenness_m_ * fbm_slope / wavelength_m_;
}

double Ground::Raw(double x, double y) const {
  return plane_gradient_.x() * x + plane_gradient_.y() * y +
         unevenness_m_ * noise_.Fbm2(x / wavelength_m_, y / wavelength_m_, kOctaves);
}

double Ground::Height(double x, double y) const { return Raw(x, y) - offset_m_; }

Eigen::Vector2d Ground::Gradient(double x, double y) const {
  const double h = 1e-3;
  return {(Raw(x + h, y) - Raw(x - h, y)) / (2 * h), (Raw(x, y + h) - Raw(x, y - h)) / (2 * h)};
}

Eigen::Vector3d Ground::Normal(double x, double y) const {
  const Eigen::Vector2d g = Gradient(x, y);
  return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

}  // namespace stemmap::sim
