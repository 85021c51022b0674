#pragma once

#include <cstdint>
#include <vector>

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

// Camera poses for every frame. The plot frame has its origin on the rotation axis at ground
// level, z up, and x along the first frame's horizontal viewing direction.
std::vector<RigFrame> SimulateRig(const RigParams& params);

}  // namespace stemmap::sim
