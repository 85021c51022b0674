#include "stemmap/sim/sensor.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"

namespace stemmap::sim {

namespace {

constexpr size_t kGaussTable = size_t{1} << 22;

// ACES-like filmic curve: soft shoulder so bright sky gaps saturate gracefully.
inline float Filmic(float x) {
  x = std::max(x, 0.0f);
  return std::clamp((x * (2.51f * x + 0.03f)) / (x * (2.43f * x + 0.59f) + 0.14f), 0.0f, 1.0f);
}

inline float SrgbEncode(float x) {
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
}

// Filmic tone curve then sRGB encoding to 8 bits, tabulated over exposed linear values; the
// table is fine enough (1/4096 below 1, coarser above where the shoulder is flat) that no output
// code changes by more than one.
class ToneTable {
 public:
  ToneTable() {
    for (int i = 0; i < kSize; ++i) {
      table_[i] = static_cast<uint8_t>(std::lround(255.0f * SrgbEncode(Filmic(Value(i)))));
    }
  }
  uint8_t operator()(float x) const {
    if (!(x > 0.0f)) return table_[0];
    const float f = x < 1.0f ? x * kFine : kFine + (x - 1.0f) * kCoarse;
    return table_[std::min(static_cast<int>(f + 0.5f), kSize - 1)];
  }

 private:
  static constexpr int kFine = 4096, kCoarse = 256, kSize = kFine + 16 * kCoarse;
  static float Value(int i) {
    return i <= kFine ? static_cast<float>(i) / kFine
                      : 1.0f + static_cast<float>(i - kFine) / kCoarse;
  }
  uint8_t table_[kSize];
};

}  // namespace

void SensorParams::Check() const {
  if (!(exposure_time_s > 0 && exposure_time_s <= 0.1)) {
    throw InputError("exposure time must be in (0, 0.1] s");
  }
  if (!(ae_time_constant_s > 0)) throw InputError("auto-exposure time constant must be positive");
}

SensorModel::SensorModel(const SensorParams& params, const PinholeCamera& camera)
    : params_(params), camera_(camera), gauss_(kGaussTable) {
  params.Check();
  Rng rng(params.seed ^ 0xA5A5);
  for (float& g : gauss_) g = static_cast<float>(rng.Normal());
  vignette_.create(camera.height, camera.width, CV_32F);
  for (int v = 0; v < camera.height; ++v) {
    float* row = vignette_.ptr<float>(v);
    for (int u = 0; u < camera.width; ++u) {
      const double du = (u - camera.cx) / camera.fx, dv = (v - camera.cy) / camera.fy;
      row[u] =
          static_cast<float>(1.0 - params.vignetting * std::min(1.0, (du * du + dv * dv) / 0.6));
    }
  }
}

double SensorModel::Meter(const cv::Mat& radiance) const {
  // Centre-weighted mean of log luminance on a sparse grid, as phone metering does.
  double sum = 0.0, wsum = 0.0;
  const int step = std::max(4, radiance.cols / 120);
  for (int v = step / 2; v < radiance.rows; v += step) {
    const auto* row = radiance.ptr<cv::Vec3f>(v);
    for (int u = step / 2; u < radiance.cols; u += step) {
      const double y = 0.2126 * row[u][0] + 0.7152 * row[u][1] + 0.0722 * row[u][2];
      const double du = (u - 0.5 * radiance.cols) / radiance.cols;
      const double dv = (v - 0.5 * radiance.rows) / radiance.rows;
      const double w = std::exp(-(du * du + dv * dv) * 4.0);
      sum += w * std::log(std::max(y, 1e-4));
      wsum += w;
    }
  }
  return std::exp(sum / wsum);
}

cv::Mat SensorModel::Capture(const RenderBuffers& frame, double yaw_rate_rad_s, double arm_radius_m,
                             int frame_index, double dt_s) {
  const cv::Mat& rad = frame.radiance;
  const int w = rad.cols, h = rad.rows;
  if (rad.size() != vignette_.size() || frame.depth_m.size() != rad.size()) {
    throw std::invalid_argument("sensor: frame size differs from the camera's");
  }
  const double target = params_.ae_target / Meter(rad);
  if (exposure_ < 0) {
    exposure_ = target;
  } else {
    const double k = 1.0 - std::exp(-dt_s / params_.ae_time_constant_s);
    exposure_ = std::exp(std::log(exposure_) + k * (std::log(target) - std::log(exposure_)));
  }
  // Image motion of a point at depth Z: fx * yaw_rate * (1 + R / Z), over the shutter time.
  const double base_px = std::abs(yaw_rate_rad_s) * params_.exposure_time_s * camera_.fx;
  cv::Mat out(h, w, CV_8UC3);
  const uint64_t frame_hash = Mix64(params_.seed ^ (static_cast<uint64_t>(frame_index) << 20));
  const float exposure = static_cast<float>(exposure_);
  static const ToneTable tone;
  // Locals, not members: the 8-bit stores below may alias anything, which would otherwise
  // reload every parameter per pixel.
  const float shot = static_cast<float>(params_.shot_noise);
  const float read = static_cast<float>(params_.read_noise);
  const float* gauss = gauss_.data();
  const size_t n = 3 * static_cast<size_t>(w);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < h; ++v) {
    const auto* row = rad.ptr<cv::Vec3f>(v);
    const float* depth = frame.depth_m.ptr<float>(v);
    std::vector<cv::Vec3f> prefix(w + 1);
    prefix[0] = cv::Vec3f(0, 0, 0);
    for (int u = 0; u < w; ++u) prefix[u + 1] = prefix[u] + row[u];
    auto integral = [&](double x) {  // ∫ of the row over [-0.5, x]
      x = std::clamp(x + 0.5, 0.0, static_cast<double>(w));
      const int i = std::min(static_cast<int>(x), w - 1);
      const float f = static_cast<float>(x - i);
      return prefix[i] + (prefix[i + 1] - prefix[i]) * f;
    };
    // Blurred, exposed and vignetted, as RGB triples.
    std::vector<float> lin(n);
    const float* vignette = vignette_.ptr<float>(v);
    for (int u = 0; u < w; ++u) {
      const double len = base_px * (1.0 + arm_radius_m / std::max(depth[u], 0.3f));
      cv::Vec3f c;
      if (len > 0.05) {
        c = (integral(u + 0.5 * len) - integral(u - 0.5 * len)) / static_cast<float>(len);
      } else {
        c = row[u];
      }
      for (int ch = 0; ch < 3; ++ch) lin[3 * u + ch] = c[ch] * exposure * vignette[u];
    }
    // Shot and read noise, one table sample per value; a plain loop over contiguous samples
    // vectorizes, so the wrap at the table's end is handled apart.
    const size_t g0 = Mix64(frame_hash + v) % kGaussTable;
    if (g0 + n <= kGaussTable) {
      const float* gv = gauss + g0;
      for (size_t k = 0; k < n; ++k) {
        lin[k] += std::sqrt(shot * std::max(lin[k], 0.0f) + read) * gv[k];
      }
    } else {
      for (size_t k = 0; k < n; ++k) {
        lin[k] +=
            std::sqrt(shot * std::max(lin[k], 0.0f) + read) * gauss[(g0 + k) & (kGaussTable - 1)];
      }
    }
    // Output is BGR; radiance is RGB.
    auto* dst = out.ptr<cv::Vec3b>(v);
    for (int u = 0; u < w; ++u) {
      for (int ch = 0; ch < 3; ++ch) dst[u][2 - ch] = tone(lin[3 * u + ch]);
    }
  }
  return out;
}

}  // namespace stemmap::sim
