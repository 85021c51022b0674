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

  double Height(double x, double y) const;
  Eigen::Vector2d Gradient(double x, double y) const;
  Eigen::Vector3d Normal(double x, double y) const;
  // Upper bound of |∇g| over the whole field; the renderer's ray march relies on it.
  double LipschitzBound() const { return lipschitz_; }
  double slope_deg() const { return slope_deg_; }
  // The field lies within ±BumpBound() of the plane PlaneHeight().
  double PlaneHeight(double x, double y) const {
    return plane_gradient_.x() * x + plane_gradient_.y() * y - offset_m_;
  }
  double BumpBound() const { return unevenness_m_ * 1.001 + 1e-6; }
  const Eigen::Vector2d& plane_gradient() const { return plane_gradient_; }

 private:
  double Raw(double x, double y) const;
  double Bump(double x, double y) const;  // unevenness only, from the table where it covers
  // The unevenness is tabulated (bilinear, fine enough that it matches the noise to < 1 mm),
  // since the renderer evaluates it millions of times per frame.
  std::vector<float> bump_table_;
  int table_n_ = 0;
  double table_step_m_ = 0.1, table_origin_m_ = 0.0;
  Eigen::Vector2d plane_gradient_ = Eigen::Vector2d::Zero();
  double unevenness_m_ = 0.0;
  double wavelength_m_ = 1.0;
  double offset_m_ = 0.0;
  double lipschitz_ = 0.0;
  double slope_deg_ = 0.0;
  ValueNoise noise_;
};

}  // namespace stemmap::sim
