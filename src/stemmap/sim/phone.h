#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/enum_names.h"
#include "stemmap/sim/rig.h"

namespace stemmap::sim {

// Cameras of a real phone, as starting points for the simulated capture's effects: `ideal` is a
// global shutter with a fixed focal length in still air; `main` a phone's main camera (a rolling
// shutter, residual distortion, focus breathing, a breeze); `wide` its ~100° wide camera.
enum class PhonePreset { kIdeal, kMain, kWide };
inline constexpr EnumNames<PhonePreset, 3> kPhonePresetNames = {
    {{PhonePreset::kIdeal, "ideal"}, {PhonePreset::kMain, "main"}, {PhonePreset::kWide, "wide"}}};
PhonePreset ParsePhonePreset(const std::string& s);
std::string ToString(PhonePreset p);
STEMMAP_ENUM_JSON(PhonePreset, kPhonePresetNames, "phone")

// What a phone camera adds to the ideal one over a clip, beyond its lens (the distortion lives
// with the lens, in SimulateOptions). All off by default.
struct PhoneOptions {
  PhonePreset preset = PhonePreset::kIdeal;  // the values' starting point (flags change them)
  // Rolling shutter: the rows are read top to bottom over this time (0: a global shutter). Row v
  // is taken at t + readout (v / (height - 1) - 1/2): a frame's time is its middle row's.
  double readout_ms = 0.0;
  // Focus breathing: the focal length is this % longer focused near (1 m and closer) and as much
  // shorter focused far (10 m and beyond), smoothly in 1 / distance between.
  double breathing_pct = 0.0;
  double focus_lag_s = 0.3;  // the autofocus follows the centre's depth with this time constant
  // Electronic stabilisation: a crop of a larger sensor image, shifted each frame to cancel the
  // camera's rotation about its x and y axes beyond its smoothed course.
  bool stabilisation = false;
  double stabilisation_crop = 1.1;      // the output's focal length over the lens's
  double stabilisation_window_s = 0.5;  // centred window that smooths the rotation
  double wind = 0.0;  // 0 still air ... 1 a fresh breeze (Wind); stems of trees never move
  void Check() const;
  // Whether the intrinsics change from frame to frame.
  bool PerFrameIntrinsics() const { return breathing_pct > 0.0 || stabilisation; }
  bool Any() const { return readout_ms > 0.0 || PerFrameIntrinsics() || wind > 0.0; }
};
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(PhoneOptions, preset, readout_ms, breathing_pct,
                                                focus_lag_s, stabilisation, stabilisation_crop,
                                                stabilisation_window_s, wind)

// Focus breathing: the focal length's scale at focus distance `focus_m`, 1 + a g with
// a = breathing_pct / 100 and g from +1 (1 m and nearer) to -1 (10 m and farther), smooth in
// 1 / distance.
double BreathingScale(double focus_m, double breathing_pct);

// An autofocus that follows the metered distance with a lag, in dioptres (1 / distance), as a
// lens moves: a step in distance is 63 % done after `lag_s`.
class Autofocus {
 public:
  Autofocus(double lag_s, double initial_m);
  // The focus distance after `dt_s` more of metering `measured_m`.
  double Update(double measured_m, double dt_s);
  double focus_m() const { return 1.0 / dioptres_; }

 private:
  double lag_s_;
  double dioptres_;
};

// The camera's rotation beyond its smoothed course, per frame: the turn from the centred
// `window_s` average of the frames' rotations to the frame's own, about the camera's x and y axes
// (rad). A stabilising crop cancels it by moving the principal point by (fx y, -fy x).
std::vector<Eigen::Vector2d> RotationJitter(const std::vector<RigFrame>& frames, double fps,
                                            double window_s);

// One frame's intrinsics: `nominal` (the output camera, crop included) with its focal lengths
// scaled by `focal_scale` and its principal point moved to cancel `jitter_rad`, no farther than
// the crop's margin.
PinholeCamera FrameCamera(const PinholeCamera& nominal, double focal_scale,
                          const Eigen::Vector2d& jitter_rad, double crop);

}  // namespace stemmap::sim
