#include "stemmap/track/residuals.h"

namespace stemmap::track {

namespace {

Eigen::Matrix3d Cross(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

}  // namespace

bool PoseReprojectionCost::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const double* pose = parameters[0];
  const Eigen::Map<const Eigen::Vector3d> u(pose), c(pose + 4), x(parameters[1]);
  const double w = pose[3], k = parameters[2][0];
  const Eigen::Vector3d d = x - c;
  const Eigen::Quaterniond q(w, u.x(), u.y(), u.z());
  const Eigen::Vector3d p = q * d;  // as the automatic version computes it
  const bool behind = p.z() < 1e-6;
  Eigen::Matrix<double, 2, 3> dr_dp;
  Eigen::Vector2d dr_dk = Eigen::Vector2d::Zero();
  if (behind) {
    residuals[0] = f_ * (p.z() - 1e-6) * -100.0;
    residuals[1] = 0.0;
    dr_dp << 0, 0, -100.0 * f_, 0, 0, 0;
  } else if (lens_.Any()) {
    const double iz = 1.0 / p.z();
    const Eigen::Vector2d n(p.x() * iz, p.y() * iz);
    const double rho = n.squaredNorm();
    const double g = lens_.Factor(rho);
    residuals[0] = f_ * (k * n.x() * g - uv_.x());
    residuals[1] = f_ * (k * n.y() * g - uv_.y());
    const Eigen::Matrix2d jd =
        g * Eigen::Matrix2d::Identity() + 2.0 * lens_.FactorSlope(rho) * n * n.transpose();
    Eigen::Matrix<double, 2, 3> dn_dp;
    dn_dp << iz, 0, -n.x() * iz, 0, iz, -n.y() * iz;
    dr_dp = f_ * k * jd * dn_dp;
    dr_dk = f_ * g * n;
  } else {
    const double iz = 1.0 / p.z();
    residuals[0] = f_ * (k * p.x() / p.z() - uv_.x());
    residuals[1] = f_ * (k * p.y() / p.z() - uv_.y());
    const double s = f_ * k * iz;
    dr_dp << s, 0, -s * p.x() * iz, 0, s, -s * p.y() * iz;
    dr_dk << f_ * p.x() / p.z(), f_ * p.y() / p.z();
  }
  if (!jacobians) return true;
  const Eigen::Matrix3d ux = Cross(u);
  const Eigen::Matrix3d m = Eigen::Matrix3d::Identity() + 2.0 * w * ux + 2.0 * ux * ux;
  if (jacobians[0]) {
    Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> j(jacobians[0]);
    const Eigen::Matrix3d dp_du =
        -2.0 * w * Cross(d) + 2.0 * (u * d.transpose() + u.dot(d) * Eigen::Matrix3d::Identity() -
                                     2.0 * d * u.transpose());
    j.block<2, 3>(0, 0) = dr_dp * dp_du;
    j.col(3) = dr_dp * (2.0 * u.cross(d));
    j.block<2, 3>(0, 4) = -dr_dp * m;
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[1]);
    j = dr_dp * m;
  }
  if (jacobians[2]) {
    jacobians[2][0] = dr_dk.x();
    jacobians[2][1] = dr_dk.y();
  }
  return true;
}

}  // namespace stemmap::track
