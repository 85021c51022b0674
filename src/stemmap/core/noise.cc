#include "stemmap/core/noise.h"

#include "stemmap/core/rng.h"

namespace stemmap {
namespace {

inline double Fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
inline double Lerp(double a, double b, double t) { return a + (b - a) * t; }

}  // namespace

ValueNoise::ValueNoise(uint64_t seed) {
  Rng rng(seed);
  for (int i = 0; i < kPeriod; ++i) {
    perm_[i] = static_cast<uint16_t>(i);
    values_[i] = static_cast<float>(rng.Uniform(-1.0, 1.0));
  }
  for (int i = kPeriod - 1; i > 0; --i) {
    const int j = static_cast<int>(rng.NextU64() % static_cast<uint64_t>(i + 1));
    std::swap(perm_[i], perm_[j]);
  }
}

double ValueNoise::Interp2(int x0, int x1, int iy, double tx, double ty) const {
  const double a = Lerp(Value(x0, iy), Value(x1, iy), tx);
  const double b = Lerp(Value(x0, iy + 1), Value(x1, iy + 1), tx);
  return Lerp(a, b, ty);
}

double ValueNoise::Noise2(double x, double y) const {
  const double fx = std::floor(x), fy = std::floor(y);
  const int ix = static_cast<int>(static_cast<int64_t>(fx) & (kPeriod - 1));
  const int iy = static_cast<int>(static_cast<int64_t>(fy) & (kPeriod - 1));
  return Interp2(ix, ix + 1, iy, Fade(x - fx), Fade(y - fy));
}

double ValueNoise::Noise2PeriodicX(double x, double y, int period) const {
  const double fx = std::floor(x), fy = std::floor(y);
  int ix = static_cast<int>(static_cast<int64_t>(fx) % period);
  if (ix < 0) ix += period;
  const int ix1 = ix + 1 == period ? 0 : ix + 1;
  const int iy = static_cast<int>(static_cast<int64_t>(fy) & (kPeriod - 1));
  return Interp2(ix, ix1, iy, Fade(x - fx), Fade(y - fy));
}

double ValueNoise::Noise3(double x, double y, double z) const {
  const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
  const int ix = static_cast<int>(static_cast<int64_t>(fx) & (kPeriod - 1));
  const int iy = static_cast<int>(static_cast<int64_t>(fy) & (kPeriod - 1));
  const int iz = static_cast<int>(static_cast<int64_t>(fz) & (kPeriod - 1));
  const double tx = Fade(x - fx), ty = Fade(y - fy), tz = Fade(z - fz);
  double c[2];
  for (int k = 0; k < 2; ++k) {
    const double a = Lerp(Value(ix, iy, iz + k), Value(ix + 1, iy, iz + k), tx);
    const double b = Lerp(Value(ix, iy + 1, iz + k), Value(ix + 1, iy + 1, iz + k), tx);
    c[k] = Lerp(a, b, ty);
  }
  return Lerp(c[0], c[1], tz);
}

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
  return sum / norm;
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
  return sum / norm;
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
  return sum / norm;
}

}  // namespace stemmap
