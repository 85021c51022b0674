#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

namespace stemmap {

// SplitMix64 step: a well-mixed 64-bit hash, used both as a seed mixer and for stateless noise.
inline uint64_t Mix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

inline uint64_t HashCombine(uint64_t a, uint64_t b) { return Mix64(a ^ Mix64(b)); }

// Uniform double in [0, 1) from a hash.
inline double HashToUnit(uint64_t h) { return static_cast<double>(h >> 11) * 0x1.0p-53; }

// A small deterministic generator (xoshiro-like quality is not needed; SplitMix64 is enough) whose
// output does not depend on the standard library, so results match across toolchains.
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(Mix64(seed ^ 0x5EED5EED5EED5EEDULL)) {}

  uint64_t NextU64() {
    state_ += 0x9E3779B97F4A7C15ULL;
    return Mix64(state_);
  }
  double Uniform() { return HashToUnit(NextU64()); }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  int UniformInt(int lo, int hi_inclusive) {
    return lo + static_cast<int>(NextU64() % static_cast<uint64_t>(hi_inclusive - lo + 1));
  }
  double Normal(double mean = 0.0, double sd = 1.0) {
    // Box-Muller; the second value is discarded to keep the state simple.
    double u1 = Uniform();
    if (u1 < 1e-300) u1 = 1e-300;
    const double u2 = Uniform();
    return mean + sd * std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }
  bool Bernoulli(double p) { return Uniform() < p; }
  // A child generator for an independent sub-stream (e.g. one per tree).
  Rng Fork(uint64_t salt) { return Rng(HashCombine(NextU64(), salt)); }

 private:
  uint64_t state_;
};

}  // namespace stemmap
