#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/sim/render.h"

namespace stemmap::sim {

// A phone camera's image pipeline after the optics: auto-exposure that lags the scene, motion
// blur from the arm's rotation, vignetting, shot and read noise, and a filmic tone curve to sRGB.
struct SensorParams {
  double exposure_time_s = 1.0 / 90.0;  // shutter time, sets the motion blur
  double ae_time_constant_s = 0.7;      // how fast auto-exposure follows the scene
  double ae_target = 0.13;              // metered mean brightness after exposure (linear)
  double vignetting = 0.25;             // brightness loss in the image corners
  double shot_noise = 0.0006;           // variance per unit of linear signal
  double read_noise = 0.00002;          // variance floor
  uint64_t seed = 0;
  void Check() const;
};

class SensorModel {
 public:
  SensorModel(const SensorParams& params, const PinholeCamera& camera);

  // Turns one frame's radiance into an 8-bit BGR image. `yaw_rate_rad_s` is the arm's rotation
  // rate; `arm_radius_m` adds the parallax of the translation to the blur of near objects.
  cv::Mat Capture(const RenderBuffers& frame, double yaw_rate_rad_s, double arm_radius_m,
                  int frame_index, double dt_s);
  double exposure() const { return exposure_; }

 private:
  double Meter(const cv::Mat& radiance) const;
  SensorParams params_;
  PinholeCamera camera_;
  double exposure_ = -1.0;
  std::vector<float> gauss_;  // precomputed standard normal samples
  cv::Mat vignette_;          // CV_32F gain per pixel
};

}  // namespace stemmap::sim
