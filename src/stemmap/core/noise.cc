#include "stemmap/core/noise.h"

#include <algorithm>

#include "stemmap/core/rng.h"

namespace stemmap {

ValueNoise::ValueNoise(uint64_t seed) {
  Rng rng(seed);
  for (int i = 0; i < kPeriod; ++i) {
    perm_[i] = static_cast<uint16_t>(i);
    values_[i] = static_cast<float>(rng.Uniform(-1.0, 1.0));
  }
  max_value_ = *std::max_element(values_.begin(), values_.end());
  for (int i = kPeriod - 1; i > 0; --i) {
    const int j = static_cast<int>(rng.NextU64() % static_cast<uint64_t>(i + 1));
    std::swap(perm_[i], perm_[j]);
  }
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
