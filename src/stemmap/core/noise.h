#pragma once

#include <array>
#include <cmath>
#include <cstdint>

namespace stemmap {

// Seeded value noise in [-1, 1] with smooth (quintic) interpolation, on a lattice that repeats
// every kPeriod units. Table-driven so the renderer can afford it per pixel; deterministic for
// any thread order.
class ValueNoise {
 public:
  static constexpr int kPeriod = 512;

  explicit ValueNoise(uint64_t seed = 0);

  inline double Noise2(double x, double y) const;
  inline double Noise3(double x, double y, double z) const;
  // Noise2 that repeats every `period` units in x (1 <= period <= kPeriod), for azimuths; with
  // its derivatives in x and y where `grad` is given.
  inline double Noise2PeriodicX(double x, double y, int period, double* grad = nullptr) const;
  // Fractal sums of `octaves` octaves, each twice the frequency and `gain` times the amplitude,
  // normalised to [-1, 1].
  inline double Fbm2(double x, double y, int octaves, double gain = 0.5) const;
  inline double Fbm3(double x, double y, double z, int octaves, double gain = 0.5) const;
  inline double Fbm2PeriodicX(double x, double y, int period, int octaves, double gain = 0.5) const;
  // No Noise2/Noise3 value exceeds this (they interpolate between lattice values).
  double MaxValue() const { return max_value_; }

 private:
  int Hash(int ix) const { return perm_[ix & (kPeriod - 1)]; }
  float Value(int ix, int iy) const { return values_[Hash(Hash(ix) + iy)]; }
  float Value(int ix, int iy, int iz) const { return values_[Hash(Hash(Hash(ix) + iy) + iz)]; }
  double Interp2(int x0, int x1, int iy, double tx, double ty) const {
    const double a = Lerp(Value(x0, iy), Value(x1, iy), tx);
    const double b = Lerp(Value(x0, iy + 1), Value(x1, iy + 1), tx);
    return Lerp(a, b, ty);
  }
  static double Fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
  static double FadeSlope(double t) { return 30.0 * t * t * (t * (t - 2.0) + 1.0); }
  static double Lerp(double a, double b, double t) { return a + (b - a) * t; }
  // floor() without a libm call on CPUs lacking SSE4.1; exact for |x| < 2^31.
  static int64_t FloorInt(double x) {
    const auto i = static_cast<int64_t>(x);
    return x < static_cast<double>(i) ? i - 1 : i;
  }

  std::array<uint16_t, kPeriod> perm_;
  std::array<float, kPeriod> values_;
  double max_value_ = 1.0;
};

// Per-pixel hot paths: defined here so they inline into the renderer.
double ValueNoise::Noise2(double x, double y) const {
  const int64_t fx = FloorInt(x), fy = FloorInt(y);
  const int ix = static_cast<int>(fx & (kPeriod - 1)), iy = static_cast<int>(fy & (kPeriod - 1));
  return Interp2(ix, ix + 1, iy, Fade(x - static_cast<double>(fx)),
                 Fade(y - static_cast<double>(fy)));
}

double ValueNoise::Noise3(double x, double y, double z) const {
  const int64_t fx = FloorInt(x), fy = FloorInt(y), fz = FloorInt(z);
  const int ix = static_cast<int>(fx & (kPeriod - 1)), iy = static_cast<int>(fy & (kPeriod - 1));
  const int iz = static_cast<int>(fz & (kPeriod - 1));
  const double tx = Fade(x - static_cast<double>(fx)), ty = Fade(y - static_cast<double>(fy));
  const double tz = Fade(z - static_cast<double>(fz));
  double c[2];
  for (int k = 0; k < 2; ++k) {
    const double a = Lerp(Value(ix, iy, iz + k), Value(ix + 1, iy, iz + k), tx);
    const double b = Lerp(Value(ix, iy + 1, iz + k), Value(ix + 1, iy + 1, iz + k), tx);
    c[k] = Lerp(a, b, ty);
  }
  return Lerp(c[0], c[1], tz);
}

double ValueNoise::Noise2PeriodicX(double x, double y, int period, double* grad) const {
  const int64_t fx = FloorInt(x), fy = FloorInt(y);
  // Azimuths come in as x in [0, period): no remainder needed there, since a division costs many
  // times more than the rest of the lookup, and this runs per bark sample.
  int ix;
  if (fx >= 0 && fx < period) {
    ix = static_cast<int>(fx);
  } else {
    ix = static_cast<int>(fx % period);
    if (ix < 0) ix += period;
  }
  const int ix1 = ix + 1 == period ? 0 : ix + 1;
  const int iy = static_cast<int>(fy & (kPeriod - 1));
  const double rx = x - static_cast<double>(fx), ry = y - static_cast<double>(fy);
  if (!grad) return Interp2(ix, ix1, iy, Fade(rx), Fade(ry));
  const double tx = Fade(rx), ty = Fade(ry);
  const double v00 = Value(ix, iy), v10 = Value(ix1, iy);
  const double v01 = Value(ix, iy + 1), v11 = Value(ix1, iy + 1);
  const double a = Lerp(v00, v10, tx), b = Lerp(v01, v11, tx);
  grad[0] = ((v10 - v00) * (1.0 - ty) + (v11 - v01) * ty) * FadeSlope(rx);
  grad[1] = (b - a) * FadeSlope(ry);
  return Lerp(a, b, ty);
}

// The sums inline too: with the octaves and gain known at the call, the loop unrolls and the
// normalisation becomes one product.
double ValueNoise::Fbm2(double x, double y, int octaves, double gain) const {
  double sum = 0.0, amp = 1.0, norm = 0.0;
  for (int o = 0; o < octaves; ++o) {
    // Offsets decorrelate octaves that would otherwise share lattice points at the origin.
    sum += amp * Noise2(x + 17.3 * o, y - 9.1 * o);
    norm += amp;
    amp *= gain;
    x *= 2.0;
    y *= 2.0;
  }
  return sum * (1.0 / norm);
}

double ValueNoise::Fbm2PeriodicX(double x, double y, int period, int octaves, double gain) const {
  double sum = 0.0, amp = 1.0, norm = 0.0;
  for (int o = 0; o < octaves && period <= kPeriod; ++o) {
    sum += amp * Noise2PeriodicX(x, y - 9.1 * o, period);
    norm += amp;
    amp *= gain;
    x *= 2.0;
    y *= 2.0;
    period *= 2;
  }
  return sum * (1.0 / norm);
}

double ValueNoise::Fbm3(double x, double y, double z, int octaves, double gain) const {
  double sum = 0.0, amp = 1.0, norm = 0.0;
  for (int o = 0; o < octaves; ++o) {
    sum += amp * Noise3(x + 17.3 * o, y - 9.1 * o, z + 5.7 * o);
    norm += amp;
    amp *= gain;
    x *= 2.0;
    y *= 2.0;
    z *= 2.0;
  }
  return sum * (1.0 / norm);
}

}  // namespace stemmap
