#include "stemmap/sim/rig.h"

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

std::vector<RigFrame> SimulateRig(const RigParams& p) {
  const int n = std::max(1, static_cast<int>(std::lround(p.seconds * p.fps)));
  ValueNoise speed_noise(HashCombine(p.seed, 11)), wobble_noise(HashCombine(p.seed, 12));

  // Angle as the integral of a smoothly varying push speed, scaled to the requested turns.
  const int sub = 8;
  std::vector<double> theta(static_cast<size_t>(n) * sub + 1, 0.0);
  for (size_t k = 1; k < theta.size(); ++k) {
    const double t = (k - 0.5) / (sub * p.fps);
    const double v =
        1.0 + p.speed_variation * std::clamp(1.6 * speed_noise.Fbm2(t / 4.0, 0.5, 2), -1.0, 1.0);
    theta[k] = theta[k - 1] + v;
  }
  const double scale = 2.0 * std::numbers::pi * p.turns / theta.back() * p.direction;
  for (double& th : theta) th *= scale;

  const Eigen::Quaterniond tilt = Rot(
      Eigen::Vector3d(-std::sin(p.stand_tilt_azimuth_rad), std::cos(p.stand_tilt_azimuth_rad), 0),
      p.stand_tilt_deg * kDeg);
  // Camera axes when the arm points along +x: looking outward (+x), right = -y, down = -z.
  Eigen::Matrix3d arm_from_cam_nominal;
  arm_from_cam_nominal << 0, 0, 1,  //
      -1, 0, 0,                     //
      0, -1, 0;
  const Eigen::Quaterniond mount =
      Eigen::Quaterniond(arm_from_cam_nominal) *
      Rot(Eigen::Vector3d::UnitY(), p.mount_yaw_deg * kDeg) *    // camera y: yaw
      Rot(Eigen::Vector3d::UnitX(), p.mount_pitch_deg * kDeg) *  // camera x: pitch
      Rot(Eigen::Vector3d::UnitZ(), p.mount_roll_deg * kDeg);    // camera z: roll

  std::vector<RigFrame> frames(n);
  for (int i = 0; i < n; ++i) {
    const double t = i / p.fps;
    const double th = theta[static_cast<size_t>(i) * sub];
    const Eigen::Quaterniond arm = Rot(Eigen::Vector3d::UnitZ(), th);
    const Eigen::Vector3d c_rig(p.arm_radius_m * std::cos(th), p.arm_radius_m * std::sin(th),
                                p.camera_height_m);
    // Wobble: smooth jitter of ~1-3 Hz in position and orientation.
    auto w = [&](int channel, double freq) {
      return wobble_noise.Fbm2(t * freq, 7.3 * channel, 2);
    };
    const Eigen::Vector3d dp = p.wobble_m * Eigen::Vector3d(w(0, 1.5), w(1, 1.7), w(2, 2.1));
    const Eigen::Quaterniond dr = Rot(Eigen::Vector3d::UnitX(), p.wobble_deg * kDeg * w(3, 1.9)) *
                                  Rot(Eigen::Vector3d::UnitY(), p.wobble_deg * kDeg * w(4, 2.3)) *
                                  Rot(Eigen::Vector3d::UnitZ(), p.wobble_deg * kDeg * w(5, 1.3));
    frames[i].t_s = t;
    frames[i].world_from_cam.translation = tilt * (c_rig + dp);
    frames[i].world_from_cam.rotation = tilt * arm * mount * dr;
    const size_t k = static_cast<size_t>(i) * sub;
    const size_t k1 = std::min(k + 1, theta.size() - 1), k0 = k1 - 1;
    frames[i].yaw_rate_rad_s = (theta[k1] - theta[k0]) * sub * p.fps;
  }

  // Plot frame: rotate about z so the first frame looks along +x horizontally.
  const Eigen::Vector3d view0 = frames[0].world_from_cam.rotation * Eigen::Vector3d::UnitZ();
  const double yaw0 = std::atan2(view0.y(), view0.x());
  const Eigen::Quaterniond align = Rot(Eigen::Vector3d::UnitZ(), -yaw0);
  for (RigFrame& f : frames) {
    f.world_from_cam.translation = align * f.world_from_cam.translation;
    f.world_from_cam.rotation = (align * f.world_from_cam.rotation).normalized();
  }
  return frames;
}

}  // namespace stemmap::sim
