#pragma once

#include <cstdint>
#include <vector>

#include "stemmap/core/noise.h"
#include "stemmap/core/pose.h"

namespace stemmap::sim {

// The capture rig: a tripod at the plot centre with a horizontal arm that is pushed round by hand.
struct RigParams {
  double arm_radius_m = 1.0;
  double camera_height_m = 1.32;  // arm height above the ground at the axis
  double turns = 1.1;             // total rotation over the clip
  double seconds = 45.0;
  double fps = 30.0;
  double stand_tilt_deg = 0.8;  // rotation axis tilt from vertical
  double stand_tilt_azimuth_rad = 0.0;
  double speed_variation = 0.25;  // relative speed changes of the hand push
  double wobble_m = 0.01;         // camera position jitter (arm flex, pushes)
  double wobble_deg = 0.5;        // camera orientation jitter
  double mount_pitch_deg = 0.0;   // fixed mount offsets of the phone on the arm
  double mount_roll_deg = 0.0;
  double mount_yaw_deg = 0.0;
  int direction = 1;  // +1 counter-clockwise seen from above, -1 clockwise
  uint64_t seed = 0;
};

struct RigFrame {
  double t_s = 0.0;
  Rigid3d world_from_cam;       // plot frame, OpenCV camera axes
  double yaw_rate_rad_s = 0.0;  // signed rotation rate about the axis (for motion blur)
};

// The rig's motion as a function of time, for instants between frames too (the rows of a rolling
// shutter). The plot frame has its origin on the rotation axis at ground level, z up, and x along
// the first frame's horizontal viewing direction.
class RigMotion {
 public:
  explicit RigMotion(const RigParams& params);

  // Camera poses for every frame, at t = i / fps.
  std::vector<RigFrame> Frames() const;
  // The camera at any time; before the first frame and after the last the arm carries on at the
  // speed it had there. At a frame's time, the same pose as Frames() gives it (to rounding).
  Rigid3d WorldFromCam(double t_s) const;

 private:
  // The pose before the turn that puts the first view along the plot's x.
  Rigid3d RawPose(double t_s, double theta_rad) const;

  RigParams p_;
  int frames_ = 1;
  static constexpr int kSubsteps = 8;  // arm angle samples per frame
  std::vector<double> theta_rad_;      // arm angle at t = k / (kSubsteps fps)
  Eigen::Quaterniond tilt_, mount_, align_;
  ValueNoise wobble_noise_;
};

// Camera poses for every frame: RigMotion(params).Frames().
std::vector<RigFrame> SimulateRig(const RigParams& params);

}  // namespace stemmap::sim
