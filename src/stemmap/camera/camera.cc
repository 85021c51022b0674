#include "stemmap/camera/camera.h"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "stemmap/core/error.h"

namespace stemmap {

PinholeCamera PinholeCamera::FromHfov(int width, int height, double hfov_deg) {
  PinholeCamera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.5 * width / std::tan(0.5 * hfov_deg * std::numbers::pi / 180.0);
  c.cx = 0.5 * (width - 1);
  c.cy = 0.5 * (height - 1);
  return c;
}

double PinholeCamera::HfovDeg() const {
  return 2.0 * std::atan(0.5 * width / fx) * 180.0 / std::numbers::pi;
}

void PinholeCamera::Check() const {
  constexpr int kMaxSidePx = 1 << 15;
  if (width <= 0 || height <= 0 || width > kMaxSidePx || height > kMaxSidePx) {
    throw InputError(fmt::format("camera size {}x{} is not positive or beyond {} px", width, height,
                                 kMaxSidePx));
  }
  if (!(fx > 0) || !(fy > 0) || !std::isfinite(fx) || !std::isfinite(fy)) {
    throw InputError(fmt::format("camera focal lengths fx={} fy={} must be positive", fx, fy));
  }
  if (!std::isfinite(cx) || !std::isfinite(cy)) {
    throw InputError(fmt::format("camera principal point ({}, {}) is not a number", cx, cy));
  }
  if (std::abs(k1) > 1.0 || std::abs(k2) > 1.0) {
    throw InputError(fmt::format("radial distortion k1={} k2={} is implausible", k1, k2));
  }
}

Eigen::Vector2d PinholeCamera::ImageFromCam(const Eigen::Vector3d& p_cam) const {
  const double x = p_cam.x() / p_cam.z(), y = p_cam.y() / p_cam.z();
  const double r2 = x * x + y * y;
  const double d = 1.0 + k1 * r2 + k2 * r2 * r2;
  return {fx * x * d + cx, fy * y * d + cy};
}

Eigen::Vector3d PinholeCamera::CamRayFromImage(const Eigen::Vector2d& px) const {
  const double xd = (px.x() - cx) / fx, yd = (px.y() - cy) / fy;
  double x = xd, y = yd;
  if (k1 != 0.0 || k2 != 0.0) {
    // Fixed-point inversion; converges in a few steps for mild distortion.
    for (int it = 0; it < 20; ++it) {
      const double r2 = x * x + y * y;
      const double d = 1.0 + k1 * r2 + k2 * r2 * r2;
      x = xd / d;
      y = yd / d;
    }
  }
  return {x, y, 1.0};
}

PinholeCamera PinholeCamera::Scaled(double s) const {
  PinholeCamera c = *this;
  c.width = static_cast<int>(std::lround(width * s));
  c.height = static_cast<int>(std::lround(height * s));
  c.fx *= s;
  c.fy *= s;
  // Pixel centres at integers: the continuous coordinate u+0.5 scales.
  c.cx = (cx + 0.5) * s - 0.5;
  c.cy = (cy + 0.5) * s - 0.5;
  return c;
}

void to_json(nlohmann::json& j, const PinholeCamera& c) {
  j = {{"width", c.width}, {"height", c.height}, {"fx", c.fx}, {"fy", c.fy},
       {"cx", c.cx},       {"cy", c.cy},         {"k1", c.k1}, {"k2", c.k2}};
}

void from_json(const nlohmann::json& j, PinholeCamera& c) {
  c.width = j.at("width").get<int>();
  c.height = j.at("height").get<int>();
  c.fx = j.at("fx").get<double>();
  c.fy = j.at("fy").get<double>();
  c.cx = j.at("cx").get<double>();
  c.cy = j.at("cy").get<double>();
  c.k1 = j.value("k1", 0.0);
  c.k2 = j.value("k2", 0.0);
}

}  // namespace stemmap
