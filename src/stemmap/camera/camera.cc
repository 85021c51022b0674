#include "stemmap/camera/camera.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>

#include "stemmap/core/error.h"

namespace stemmap {

namespace {

// The first undistorted radius (normalised) up to `limit` where the distorted radius stops
// growing, or infinity: undistortion is one-to-one only inside it. Marched in small steps, each
// checking the slope and that the distorted radius still grew.
double FoldRadius(const PinholeCamera& c, double limit) {
  constexpr double kStep = 1e-3;
  double previous = 0.0;
  for (double r = kStep; r <= limit + kStep; r += kStep) {
    const double r2 = r * r;
    const double value = r * c.DistortionFactor(r2);
    const double slope = 1.0 + 3.0 * c.k1 * r2 + 5.0 * c.k2 * r2 * r2 + 7.0 * c.k3 * r2 * r2 * r2;
    if (!(slope > 0.0) || !(value > previous)) return r;
    previous = value;
  }
  return std::numeric_limits<double>::infinity();
}

}  // namespace

PinholeCamera PinholeCamera::FromHfov(int width, int height, double hfov_deg) {
  PinholeCamera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.5 * width / std::tan(0.5 * hfov_deg * std::numbers::pi / 180.0);
  c.cx = 0.5 * (width - 1);
  c.cy = 0.5 * (height - 1);
  return c;
}

PinholeCamera PinholeCamera::FromLensHfov(int width, int height, double hfov_deg, double k1,
                                          double k2, double k3) {
  PinholeCamera c = FromHfov(width, height, hfov_deg);
  c.k1 = k1;
  c.k2 = k2;
  c.k3 = k3;
  if (!c.HasDistortion()) return c;
  const double t = std::tan(0.5 * hfov_deg * std::numbers::pi / 180.0);
  const double edge = t * c.DistortionFactor(t * t);  // distorted radius of the edge rays
  // Beyond a fold the edge's radius would belong to a ray nearer the axis too.
  if (!(t > 0) || !(edge > 0) || !std::isfinite(edge) || FoldRadius(c, t) <= t) {
    throw InputError(
        fmt::format("a lens with k1={} k2={} k3={} cannot show a {}° field", k1, k2, k3, hfov_deg));
  }
  c.fx = c.fy = 0.5 * width / edge;
  return c;
}

double PinholeCamera::HfovDeg() const {
  return 2.0 * std::atan(0.5 * width / fx) * 180.0 / std::numbers::pi;
}

double PinholeCamera::LensHfovDeg() const {
  return 2.0 * std::atan(UndistortedRadius(0.5 * width / fx)) * 180.0 / std::numbers::pi;
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
  if (!(std::abs(k1) <= 1.0) || !(std::abs(k2) <= 1.0) || !(std::abs(k3) <= 1.0)) {
    throw InputError(fmt::format("radial distortion k1={} k2={} k3={} is implausible", k1, k2, k3));
  }
  if (!HasDistortion()) return;
  // Undistortion is one-to-one only while the distorted radius grows with the undistorted one:
  // it must grow out to the image's farthest corner.
  double corner = 0.0;
  for (const double u : {-0.5, width - 0.5}) {
    for (const double v : {-0.5, height - 0.5}) {
      corner = std::max(corner, std::hypot((u - cx) / fx, (v - cy) / fy));
    }
  }
  constexpr double kMaxRadius = 10.0;  // 84° off the axis: beyond any phone lens
  const double fold = FoldRadius(*this, kMaxRadius);
  if (std::isfinite(fold) ? fold * DistortionFactor(fold * fold) <= corner
                          : kMaxRadius * DistortionFactor(kMaxRadius * kMaxRadius) < corner) {
    if (std::isfinite(fold)) {
      throw InputError(fmt::format(
          "radial distortion k1={} k2={} k3={} folds over {:.0f}° off the axis, inside the image",
          k1, k2, k3, std::atan(fold) * 180.0 / std::numbers::pi));
    }
    throw InputError(fmt::format(
        "radial distortion k1={} k2={} k3={} would need rays beyond 84° off the axis to fill the "
        "image",
        k1, k2, k3));
  }
}

double PinholeCamera::UndistortedRadius(double r_distorted) const {
  if (!HasDistortion() || !(r_distorted > 0.0)) return r_distorted;
  // Newton's method on f(r) = r D(r²) - r_d. The fixed-point iteration r = r_d / D(r²) gains only
  // a factor of ~3 a step near the corners of a strong wide-angle lens (and fails where the
  // distortion is stronger still); Newton needs a handful of steps anywhere. The root
  // stays bracketed by [lo, hi] (f(0) < 0), and a step that would leave the bracket, or a slope
  // that is not positive (beyond a fold), falls back to bisection or to doubling r.
  double lo = 0.0, hi = std::numeric_limits<double>::infinity();
  double r = r_distorted;
  for (int it = 0; it < 100; ++it) {
    const double r2 = r * r;
    const double f = r * DistortionFactor(r2) - r_distorted;
    if (f == 0.0) return r;
    if (f < 0.0) {
      lo = r;
    } else {
      hi = r;
    }
    const double slope = 1.0 + 3.0 * k1 * r2 + 5.0 * k2 * r2 * r2 + 7.0 * k3 * r2 * r2 * r2;
    double next = slope > 0.0 ? r - f / slope : lo;
    if (!(next > lo && next < hi)) next = std::isfinite(hi) ? 0.5 * (lo + hi) : 2.0 * r;
    if (std::abs(next - r) <= 1e-15 * r) return next;
    r = next;
  }
  return r;
}

Eigen::Vector3d PinholeCamera::UndistortedRay(double xd, double yd) const {
  // The distortion is radial: undistort the radius, keep the direction.
  const double rd = std::sqrt(xd * xd + yd * yd);
  if (rd == 0.0) return {xd, yd, 1.0};
  const double s = UndistortedRadius(rd) / rd;
  return {xd * s, yd * s, 1.0};
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
  // Written only where it is used, so that the files of a two-term lens stay as they were.
  if (c.k3 != 0.0) j["k3"] = c.k3;
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
  c.k3 = j.value("k3", 0.0);
}

}  // namespace stemmap
