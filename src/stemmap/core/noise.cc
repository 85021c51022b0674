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

}  // namespace stemmap
