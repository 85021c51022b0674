#pragma once

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

namespace stemmap {

// Pinhole camera with two-term radial distortion (OpenCV's k1, k2; no tangential terms).
// Camera axes follow OpenCV: x right, y down, z forward. Pixel centres are at integer coordinates.
struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0.0, fy = 0.0;  // px
  double cx = 0.0, cy = 0.0;  // px
  double k1 = 0.0, k2 = 0.0;  // radial distortion on normalised coordinates

  // Square pixels, principal point at the image centre, no distortion.
  static PinholeCamera FromHfov(int width, int height, double hfov_deg);

  double HfovDeg() const;
  // Throws InputError when sizes or focal lengths are not positive or distortion is implausible.
  void Check() const;

  // Pixel of a point in camera coordinates (z > 0 required by the caller).
  Eigen::Vector2d ImageFromCam(const Eigen::Vector3d& p_cam) const;
  // Unit-z ray (x, y, 1) through a pixel, with distortion removed.
  Eigen::Vector3d CamRayFromImage(const Eigen::Vector2d& px) const;
  // Same camera for an image scaled by `s` (e.g. a working resolution).
  PinholeCamera Scaled(double s) const;
};

void to_json(nlohmann::json& j, const PinholeCamera& c);
void from_json(const nlohmann::json& j, PinholeCamera& c);

}  // namespace stemmap
