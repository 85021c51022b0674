#pragma once

#include <Eigen/Core>
#include <nlohmann/json_fwd.hpp>

namespace stemmap {

// Pinhole camera with three-term radial distortion (OpenCV's k1, k2, k3; no tangential terms).
// Camera axes follow OpenCV: x right, y down, z forward. Pixel centres are at integer coordinates.
struct PinholeCamera {
  int width = 0;
  int height = 0;
  double fx = 0.0, fy = 0.0;            // px
  double cx = 0.0, cy = 0.0;            // px
  double k1 = 0.0, k2 = 0.0, k3 = 0.0;  // radial distortion on normalised coordinates

  // Square pixels, principal point at the image centre, no distortion.
  static PinholeCamera FromHfov(int width, int height, double hfov_deg);
  // The same with radial distortion, the focal length chosen so that the rays through the left
  // and right image edges are `hfov_deg` apart through the lens. Throws InputError where the lens
  // cannot show that field.
  static PinholeCamera FromLensHfov(int width, int height, double hfov_deg, double k1, double k2,
                                    double k3);

  // Field of view of the pinhole part alone, 2 atan(w / 2 fx): the distortion left out.
  double HfovDeg() const;
  // Field of view between the left and right image edges through the lens (HfovDeg() where there
  // is no distortion).
  double LensHfovDeg() const;
  // Throws InputError when sizes or focal lengths are not positive or distortion is implausible:
  // a coefficient beyond ±1, or a radial map that folds over (stops growing) before the image
  // corners, where a pixel would see two directions.
  void Check() const;

  bool HasDistortion() const { return k1 != 0.0 || k2 != 0.0 || k3 != 0.0; }
  // Distorted over undistorted radius at a squared undistorted radius r2 (normalised).
  double DistortionFactor(double r2) const {
    return 1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
  }
  // The undistorted radius whose distorted radius is `r_distorted` (normalised coordinates).
  double UndistortedRadius(double r_distorted) const;
  // The unit-z ray whose distorted normalised coordinates are (xd, yd).
  Eigen::Vector3d UndistortedRay(double xd, double yd) const;

  // Pixel of a point in camera coordinates (z > 0 required by the caller). Inline, as are rays
  // through pixels: silhouette searches call both for every pixel of their windows.
  Eigen::Vector2d ImageFromCam(const Eigen::Vector3d& p_cam) const {
    const double x = p_cam.x() / p_cam.z(), y = p_cam.y() / p_cam.z();
    const double d = DistortionFactor(x * x + y * y);
    return {fx * x * d + cx, fy * y * d + cy};
  }
  // Unit-z ray (x, y, 1) through a pixel, with distortion removed.
  Eigen::Vector3d CamRayFromImage(const Eigen::Vector2d& px) const {
    const double xd = (px.x() - cx) / fx, yd = (px.y() - cy) / fy;
    if (!HasDistortion()) return {xd, yd, 1.0};
    return UndistortedRay(xd, yd);
  }
  // Same camera for an image scaled by `s` (e.g. a working resolution).
  PinholeCamera Scaled(double s) const;
};

void to_json(nlohmann::json& j, const PinholeCamera& c);
void from_json(const nlohmann::json& j, PinholeCamera& c);

}  // namespace stemmap
