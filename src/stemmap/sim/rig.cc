#include "stemmap/sim/rig.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "stemmap/core/noise.h"
#include "stemmap/core/rng.h"
#include "stemmap/core/units.h"

namespace stemmap::sim {

namespace {

Eigen::Quaterniond Rot(const Eigen::Vector3d& axis, double angle_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, axis));
}

}  // namespace

RigMotion::RigMotion(const RigParams& p)
    : p_(p),
      frames_(std::max(1, static_cast<int>(std::lround(p.seconds * p.fps)))),
      wobble_noise_(HashCombine(p.seed, 12)) {
  ValueNoise speed_noise(HashCombine(p.seed, 11));
  // Angle as the integral of a smoothly varying push speed, scaled to the requested turns.
  const int sub = kSubsteps;
  theta_rad_.assign(static_cast<size_t>(frames_) * sub + 1, 0.0);
  std::vector<double>& theta = theta_rad_;
  for (size_t k = 1; k < theta.size(); ++k) {
    const double t = (k - 0.5) / (sub * p.fps);
    const double v =
        1.0 + p.speed_variation * std::clamp(1.6 * speed_noise.Fbm2(t / 4.0, 0.5, 2), -1.0, 1.0);
    theta[k] = theta[k - 1] + v;
  }
  const double scale = 2.0 * std::numbers::pi * p.turns / theta.back() * p.direction;
  for (double& th : theta) th *= scale;

  tilt_ = Rot(
      Eigen::Vector3d(-std::sin(p.stand_tilt_azimuth_rad), std::cos(p.stand_tilt_azimuth_rad), 0),
      p.stand_tilt_deg * kDeg);
  // Camera axes when the arm points along +x: looking outward (+x), right = -y, down = -z.
  Eigen::Matrix3d arm_from_cam_nominal;
  arm_from_cam_nominal << 0, 0, 1,  //
      -1, 0, 0,                     //
      0, -1, 0;
  mount_ = Eigen::Quaterniond(arm_from_cam_nominal) *
           Rot(Eigen::Vector3d::UnitY(), p.mount_yaw_deg * kDeg) *    // camera y: yaw
           Rot(Eigen::Vector3d::UnitX(), p.mount_pitch_deg * kDeg) *  // camera x: pitch
           Rot(Eigen::Vector3d::UnitZ(), p.mount_roll_deg * kDeg);    // camera z: roll

  // Plot frame: rotate about z so the first frame looks along +x horizontally.
  const Eigen::Vector3d view0 = RawPose(0.0, theta[0]).rotation * Eigen::Vector3d::UnitZ();
  const double yaw0 = std::atan2(view0.y(), view0.x());
  align_ = Rot(Eigen::Vector3d::UnitZ(), -yaw0);
}

Rigid3d RigMotion::RawPose(double t, double th) const {
  const Eigen::Quaterniond arm = Rot(Eigen::Vector3d::UnitZ(), th);
  const Eigen::Vector3d c_rig(p_.arm_radius_m * std::cos(th), p_.arm_radius_m * std::sin(th),
                              p_.camera_height_m);
  // Wobble: smooth jitter of ~1-3 Hz in position and orientation.
  auto w = [&](int channel, double freq) { return wobble_noise_.Fbm2(t * freq, 7.3 * channel, 2); };
  const Eigen::Vector3d dp = p_.wobble_m * Eigen::Vector3d(w(0, 1.5), w(1, 1.7), w(2, 2.1));
  const Eigen::Quaterniond dr = Rot(Eigen::Vector3d::UnitX(), p_.wobble_deg * kDeg * w(3, 1.9)) *
                                Rot(Eigen::Vector3d::UnitY(), p_.wobble_deg * kDeg * w(4, 2.3)) *
                                Rot(Eigen::Vector3d::UnitZ(), p_.wobble_deg * kDeg * w(5, 1.3));
  return {tilt_ * arm * mount_ * dr, tilt_ * (c_rig + dp)};
}

std::vector<RigFrame> RigMotion::Frames() const {
  const int sub = kSubsteps;
  const std::vector<double>& theta = theta_rad_;
  std::vector<RigFrame> frames(frames_);
  for (int i = 0; i < frames_; ++i) {
    const double t = i / p_.fps;
    const Rigid3d raw = RawPose(t, theta[static_cast<size_t>(i) * sub]);
    frames[i].t_s = t;
    frames[i].world_from_cam.translation = align_ * raw.translation;
    frames[i].world_from_cam.rotation = (align_ * raw.rotation).normalized();
    const size_t k = static_cast<size_t>(i) * sub;
    const size_t k1 = std::min(k + 1, theta.size() - 1), k0 = k1 - 1;
    frames[i].yaw_rate_rad_s = (theta[k1] - theta[k0]) * sub * p_.fps;
  }
  return frames;
}

Rigid3d RigMotion::WorldFromCam(double t_s) const {
  // The arm angle between its samples, linearly; beyond the ends along the end samples' slope.
  const double k = t_s * kSubsteps * p_.fps;
  const size_t last = theta_rad_.size() - 2;
  const size_t k0 = k <= 0.0 ? 0 : std::min(static_cast<size_t>(k), last);
  const double th = theta_rad_[k0] + (k - k0) * (theta_rad_[k0 + 1] - theta_rad_[k0]);
  const Rigid3d raw = RawPose(t_s, th);
  return {(align_ * raw.rotation).normalized(), align_ * raw.translation};
}

std::vector<RigFrame> SimulateRig(const RigParams& params) { return RigMotion(params).Frames(); }

}  // namespace stemmap::sim
