#pragma once

// Ceres residuals for the circle-constrained bundle adjustment. Poses are cam_from_world
// rotations (Eigen quaternion, x y z w storage) with camera centres in the axis frame: origin at
// the centre of the arm circle, z along the rotation axis.

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace stemmap::track {

// The lens's radial distortion on normalised coordinates (OpenCV's k1-k3):
//   D(p) = p g(rho),   g = 1 + k1 rho + k2 rho^2 + k3 rho^3,   rho = |p|^2.
struct RadialLens {
  double k1 = 0.0, k2 = 0.0, k3 = 0.0;
  bool Any() const { return k1 != 0.0 || k2 != 0.0 || k3 != 0.0; }
  template <typename T>
  T Factor(const T& rho) const {
    return T(1) + rho * (T(k1) + rho * (T(k2) + rho * T(k3)));
  }
  // dg/drho
  double FactorSlope(double rho) const { return k1 + rho * (2.0 * k2 + rho * 3.0 * k3); }
  Eigen::Vector2d Distort(const Eigen::Vector2d& p) const { return p * Factor(p.squaredNorm()); }
};

// The lens's radial scale d|D(p)| / d|p| = g + 2 rho g'(rho) at rho = |p|^2: 1 at the centre,
// falling towards a wide lens's edge, where the picture is squeezed.
inline double RadialScaleAt(const RadialLens& lens, double rho) {
  return lens.Factor(rho) + 2.0 * rho * lens.FactorSlope(rho);
}

// Reprojection error in pixels of a world point X seen at normalised image point (u, v) (the
// lens's distortion removed), with a focal scale k (1 = the starting focal length f, refined from
// the closed turn):
//   P = cam_from_world * (X - c),   r = f * (k * P.x / P.z - u, k * P.y / P.z - v).
// f turns normalised units into pixels so robust-loss thresholds read in pixels.
// With a distorting lens the focal length scales what the lens gives, not the undistorted ray: a
// pixel lies at c + f k D(p), which is how the refined camera (focal f k, the same k1-k3) images
// p afterwards. The residual is then taken there:
//   r = f * (k D(p) - D(u, v)),   p = (P.x / P.z, P.y / P.z),
// the same as above for a lens without distortion, for which it is left as it was.
struct ReprojectionError {
  ReprojectionError(const Eigen::Vector2d& uv, double focal_px, const RadialLens& lens = {})
      : uv_(lens.Any() ? lens.Distort(uv) : uv), f_(focal_px), lens_(lens) {}

  template <typename T>
  bool operator()(const T* q_cam_from_world, const T* c_world, const T* x_world,
                  const T* focal_scale, T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_cam_from_world);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> c(c_world), x(x_world);
    const Eigen::Matrix<T, 3, 1> p = q * (x - c);
    if (p.z() < T(1e-6)) {  // behind the camera: a large, smooth penalty instead of a failure
      r[0] = T(f_) * (p.z() - T(1e-6)) * T(-100);
      r[1] = T(0);
      return true;
    }
    if (!lens_.Any()) {
      r[0] = T(f_) * (focal_scale[0] * p.x() / p.z() - T(uv_.x()));
      r[1] = T(f_) * (focal_scale[0] * p.y() / p.z() - T(uv_.y()));
      return true;
    }
    const T nx = p.x() / p.z(), ny = p.y() / p.z();
    const T g = lens_.Factor(nx * nx + ny * ny);
    r[0] = T(f_) * (focal_scale[0] * nx * g - T(uv_.x()));
    r[1] = T(f_) * (focal_scale[0] * ny * g - T(uv_.y()));
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& uv, double focal_px,
                                     const RadialLens& lens = {}) {
    return new ceres::AutoDiffCostFunction<ReprojectionError, 2, 4, 3, 3, 1>(
        new ReprojectionError(uv, focal_px, lens));
  }

 private:
  Eigen::Vector2d uv_;  // the observation as the lens gives it: D(u, v)
  double f_;
  RadialLens lens_;
};

// Soft prior that the camera centre lies on the arm circle: radius R in the plane z = 0.
//   r = ((|c_xy| - R) / sigma_radius, c_z / sigma_height).
// Its radius term fixes the metric scale; a tilted stand or a flexing arm moves the centre off the
// circle by about a centimetre, so sigma is of that order and the loss is robust.
struct CirclePriorError {
  CirclePriorError(double radius_m, double sigma_radius_m, double sigma_height_m)
      : radius_(radius_m), sr_(sigma_radius_m), sz_(sigma_height_m) {}

  template <typename T>
  bool operator()(const T* c_world, T* r) const {
    const T rho = ceres::sqrt(c_world[0] * c_world[0] + c_world[1] * c_world[1] + T(1e-12));
    r[0] = (rho - T(radius_)) / T(sr_);
    r[1] = c_world[2] / T(sz_);
    return true;
  }

  static ceres::CostFunction* Create(double radius_m, double sigma_radius_m,
                                     double sigma_height_m) {
    return new ceres::AutoDiffCostFunction<CirclePriorError, 2, 3>(
        new CirclePriorError(radius_m, sigma_radius_m, sigma_height_m));
  }

 private:
  double radius_, sr_, sz_;
};

// Soft prior that the phone is rigid on the arm: world_from_cam = Rz(phi) * mount, with
// phi = atan2(c_y, c_x) the arm angle of the camera centre and `mount` one rotation shared by all
// frames (arm_from_cam). r = log(expected^-1 * actual) / sigma (axis-angle vector, rad).
struct MountPriorError {
  explicit MountPriorError(double sigma_rad) : sigma_(sigma_rad) {}

  template <typename T>
  bool operator()(const T* q_cam_from_world, const T* c_world, const T* q_arm_from_cam,
                  T* r) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q_cw(q_cam_from_world), q_mount(q_arm_from_cam);
    const T phi = ceres::atan2(c_world[1], c_world[0]);
    const Eigen::Quaternion<T> rz(ceres::cos(phi / T(2)), T(0), T(0), ceres::sin(phi / T(2)));
    // expected^-1 * actual = (rz * mount)^-1 * q_cw^-1 = (q_cw * rz * mount)^-1
    const Eigen::Quaternion<T> d = q_cw * rz * q_mount;
    const T qd[4] = {d.w(), -d.x(), -d.y(), -d.z()};
    T aa[3];
    ceres::QuaternionToAngleAxis(qd, aa);
    for (int i = 0; i < 3; ++i) r[i] = aa[i] / T(sigma_);
    return true;
  }

  static ceres::CostFunction* Create(double sigma_rad) {
    return new ceres::AutoDiffCostFunction<MountPriorError, 3, 4, 3, 4>(
        new MountPriorError(sigma_rad));
  }

 private:
  double sigma_;
};

// Fixes the yaw gauge: the first camera centre lies on the +x axis (r = c_y / sigma).
struct YawGaugeError {
  template <typename T>
  bool operator()(const T* c_world, T* r) const {
    r[0] = c_world[1] / T(1e-3);
    return true;
  }
  static ceres::CostFunction* Create() {
    return new ceres::AutoDiffCostFunction<YawGaugeError, 1, 3>(new YawGaugeError);
  }
};

// The same residuals on one 7-double keyframe pose block [q_cam_from_world (x, y, z, w), c_world]:
// one block per keyframe halves the blocks the Schur eliminator visits and lets Ceres use its
// (2, 3, 6) specialisation.
struct PoseReprojectionError {
  PoseReprojectionError(const Eigen::Vector2d& uv, double focal_px, const RadialLens& lens = {})
      : e_(uv, focal_px, lens) {}
  template <typename T>
  bool operator()(const T* pose, const T* x_world, const T* focal_scale, T* r) const {
    return e_(pose, pose + 4, x_world, focal_scale, r);
  }
  static ceres::CostFunction* Create(const Eigen::Vector2d& uv, double focal_px,
                                     const RadialLens& lens = {}) {
    return new ceres::AutoDiffCostFunction<PoseReprojectionError, 2, 7, 3, 1>(
        new PoseReprojectionError(uv, focal_px, lens));
  }

 private:
  ReprojectionError e_;
};

// PoseReprojectionError with hand-written derivatives: bundle adjustment evaluates it for every
// observation in every iteration, and automatic differentiation spends most of that on 11-wide
// dual numbers. Same residual, same derivatives (to rounding).
//
// With q = (u, w) as stored and d = X - c, Eigen rotates d as
//   P = d + 2w (u x d) + 2 u x (u x d) = M d,   M = I + 2w [u]x + 2 [u]x^2,
// so dP/dX = M, dP/dc = -M, dP/dw = 2 (u x d) and, from u x (u x d) = u (u.d) - d (u.u),
//   dP/du = -2w [d]x + 2 (u d^T + (u.d) I - 2 d u^T).
// The projection r = f (k P.x / P.z - u0, k P.y / P.z - v0) has
//   dr/dP = f k [1/P.z, 0, -P.x/P.z^2; 0, 1/P.z, -P.y/P.z^2],   dr/dk = f (P.x/P.z, P.y/P.z),
// and behind the camera r = (-100 f (P.z - 1e-6), 0), so dr/dP = (0, 0, -100 f; 0, 0, 0).
// With a distorting lens, r = f (k D(p) - D(u, v)) with p = (P.x / P.z, P.y / P.z) has
//   dr/dP = f k J_D dp/dP,   J_D = g I + 2 g'(rho) p p^T,   dr/dk = f D(p).
class PoseReprojectionCost : public ceres::SizedCostFunction<2, 7, 3, 1> {
 public:
  PoseReprojectionCost(const Eigen::Vector2d& uv, double focal_px, const RadialLens& lens = {})
      : uv_(lens.Any() ? lens.Distort(uv) : uv), f_(focal_px), lens_(lens) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  static ceres::CostFunction* Create(const Eigen::Vector2d& uv, double focal_px,
                                     const RadialLens& lens = {}) {
    return new PoseReprojectionCost(uv, focal_px, lens);
  }

 private:
  Eigen::Vector2d uv_;  // the observation as the lens gives it: D(u, v)
  double f_;
  RadialLens lens_;
};

struct PoseCirclePriorError {
  PoseCirclePriorError(double radius_m, double sigma_radius_m, double sigma_height_m)
      : e_(radius_m, sigma_radius_m, sigma_height_m) {}
  template <typename T>
  bool operator()(const T* pose, T* r) const {
    return e_(pose + 4, r);
  }
  static ceres::CostFunction* Create(double radius_m, double sigma_radius_m,
                                     double sigma_height_m) {
    return new ceres::AutoDiffCostFunction<PoseCirclePriorError, 2, 7>(
        new PoseCirclePriorError(radius_m, sigma_radius_m, sigma_height_m));
  }

 private:
  CirclePriorError e_;
};

struct PoseMountPriorError {
  explicit PoseMountPriorError(double sigma_rad) : e_(sigma_rad) {}
  template <typename T>
  bool operator()(const T* pose, const T* q_arm_from_cam, T* r) const {
    return e_(pose, pose + 4, q_arm_from_cam, r);
  }
  static ceres::CostFunction* Create(double sigma_rad) {
    return new ceres::AutoDiffCostFunction<PoseMountPriorError, 3, 7, 4>(
        new PoseMountPriorError(sigma_rad));
  }

 private:
  MountPriorError e_;
};

struct PoseYawGaugeError {
  template <typename T>
  bool operator()(const T* pose, T* r) const {
    return YawGaugeError()(pose + 4, r);
  }
  static ceres::CostFunction* Create() {
    return new ceres::AutoDiffCostFunction<PoseYawGaugeError, 1, 7>(new PoseYawGaugeError);
  }
};

// Soft prior that a keyframe's focal length stays near the one the keyframes share (focus
// breathing changes it by up to about 1 %): with k_i the keyframe's focal scale and k the shared
// one (both over the starting focal length),
//   r = (k_i / k - 1) / sigma.
// The shared scale appears in no reprojection residual once the keyframes have their own, so
// these priors alone place it: at the keyframes' mean, to first order.
struct KeyframeFocalPriorError {
  explicit KeyframeFocalPriorError(double sigma) : sigma_(sigma) {}

  template <typename T>
  bool operator()(const T* keyframe_scale, const T* shared_scale, T* r) const {
    r[0] = (keyframe_scale[0] / shared_scale[0] - T(1)) / T(sigma_);
    return true;
  }

  static ceres::CostFunction* Create(double sigma) {
    return new ceres::AutoDiffCostFunction<KeyframeFocalPriorError, 1, 1, 1>(
        new KeyframeFocalPriorError(sigma));
  }

 private:
  double sigma_;
};

}  // namespace stemmap::track
