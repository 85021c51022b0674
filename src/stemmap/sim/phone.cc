#include "stemmap/sim/phone.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/sim/simulate.h"

namespace stemmap::sim {

PhonePreset ParsePhonePreset(const std::string& s) {
  return EnumFromName(kPhonePresetNames, s, "phone");
}

std::string ToString(PhonePreset p) { return std::string(EnumName(kPhonePresetNames, p)); }

void PhoneOptions::Check() const {
  if (!(readout_ms >= 0.0 && readout_ms <= 100.0)) {
    throw InputError(fmt::format("--readout-ms {} out of [0, 100]", readout_ms));
  }
  if (!(breathing_pct >= 0.0 && breathing_pct <= 5.0)) {
    throw InputError(fmt::format("--breathing-pct {} out of [0, 5]", breathing_pct));
  }
  if (!(focus_lag_s > 0.0 && focus_lag_s <= 5.0)) {
    throw InputError(fmt::format("focus lag {} s out of (0, 5]", focus_lag_s));
  }
  if (!(stabilisation_crop >= 1.0 && stabilisation_crop <= 1.5)) {
    throw InputError(fmt::format("stabilisation crop {} out of [1, 1.5]", stabilisation_crop));
  }
  if (!(stabilisation_window_s >= 0.05 && stabilisation_window_s <= 5.0)) {
    throw InputError(
        fmt::format("stabilisation window {} s out of [0.05, 5]", stabilisation_window_s));
  }
  if (!(wind >= 0.0 && wind <= 1.0)) throw InputError(fmt::format("--wind {} out of [0, 1]", wind));
}

void ApplyPhonePreset(PhonePreset preset, SimulateOptions* o) {
  PhoneOptions& p = o->phone;
  p = PhoneOptions{};
  p.preset = preset;
  o->hfov_deg = 0.0;
  o->k1 = o->k2 = o->k3 = 0.0;
  switch (preset) {
    case PhonePreset::kIdeal:
      break;
    case PhonePreset::kMain:
      // A main camera: distortion corrected in the phone but for a residue, a CMOS readout of a
      // 1080p video mode, the lens moving a little to focus, a breeze.
      o->k1 = 0.02;
      o->k2 = -0.01;
      p.readout_ms = 25.0;
      p.breathing_pct = 0.7;
      p.wind = 0.5;
      break;
    case PhonePreset::kWide:
      // A wide camera recording without distortion correction: strong barrel distortion over
      // 100°, a slower readout, a fixed-focus-like lens that hardly breathes.
      o->hfov_deg = 100.0;
      o->k1 = -0.25;
      o->k2 = 0.07;
      o->k3 = -0.008;
      p.readout_ms = 30.0;
      p.breathing_pct = 0.2;
      p.wind = 0.5;
      break;
  }
}

double BreathingScale(double focus_m, double breathing_pct) {
  constexpr double kNearDioptres = 1.0, kFarDioptres = 0.1;  // 1 m, 10 m
  const double x = std::clamp(
      (1.0 / std::max(focus_m, 1e-3) - kFarDioptres) / (kNearDioptres - kFarDioptres), 0.0, 1.0);
  const double g = 2.0 * x * x * (3.0 - 2.0 * x) - 1.0;  // smoothstep from -1 to +1
  return 1.0 + 0.01 * breathing_pct * g;
}

Autofocus::Autofocus(double lag_s, double initial_m)
    : lag_s_(lag_s), dioptres_(1.0 / std::max(initial_m, 1e-3)) {}

double Autofocus::Update(double measured_m, double dt_s) {
  const double k = 1.0 - std::exp(-dt_s / lag_s_);
  dioptres_ += k * (1.0 / std::max(measured_m, 1e-3) - dioptres_);
  return focus_m();
}

std::vector<Eigen::Vector2d> RotationJitter(const std::vector<RigFrame>& frames, double fps,
                                            double window_s) {
  const int n = static_cast<int>(frames.size());
  const int half = std::max(0, static_cast<int>(std::lround(0.5 * window_s * fps)));
  std::vector<Eigen::Vector2d> jitter(n, Eigen::Vector2d::Zero());
  for (int i = 0; i < n; ++i) {
    // A window centred on the frame, narrowed at the clip's ends so that it stays centred.
    const int h = std::min({half, i, n - 1 - i});
    const Eigen::Quaterniond& q_i = frames[i].world_from_cam.rotation;
    Eigen::Vector4d sum = Eigen::Vector4d::Zero();
    for (int j = i - h; j <= i + h; ++j) {
      const Eigen::Quaterniond& q = frames[j].world_from_cam.rotation;
      sum += (q.coeffs().dot(q_i.coeffs()) < 0.0 ? -1.0 : 1.0) * q.coeffs();  // one hemisphere
    }
    const Eigen::Quaterniond smooth = Eigen::Quaterniond(sum).normalized();
    // smooth_from_cam: the frame's camera seen from the smoothed one, as a rotation vector.
    const Eigen::AngleAxisd turn(smooth.conjugate() * q_i);
    const Eigen::Vector3d v = turn.angle() * turn.axis();
    jitter[i] = v.head<2>();
  }
  return jitter;
}

PinholeCamera FrameCamera(const PinholeCamera& nominal, double focal_scale,
                          const Eigen::Vector2d& jitter_rad, double crop) {
  PinholeCamera c = nominal;
  c.fx *= focal_scale;
  c.fy *= focal_scale;
  // A camera turned right (about +y) by y beyond its smoothed course sees the scene moved left
  // by fx y; the crop window follows the scene, which leaves the optical axis (the principal
  // point) fx y right of the crop's centre. Likewise up (about +x) by x: fy x above it.
  const double margin_x = 0.5 * (crop - 1.0) * c.width, margin_y = 0.5 * (crop - 1.0) * c.height;
  c.cx = nominal.cx + std::clamp(c.fx * jitter_rad.y(), -margin_x, margin_x);
  c.cy = nominal.cy + std::clamp(-c.fy * jitter_rad.x(), -margin_y, margin_y);
  return c;
}

}  // namespace stemmap::sim
