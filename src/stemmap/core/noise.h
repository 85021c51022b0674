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

  double Noise2(double x, double y) const;
  double Noise3(double x, double y, double z) const;
  // Noise2 that repeats every `period` units in x (1 <= period <= kPeriod), for azimuths.
  double Noise2PeriodicX(double x, double y, int period) const;
  // Fractal sums of `octaves` octaves, each twice the frequency and `gain` times the amplitude,
  // normalised to [-1, 1].
  double Fbm2(double x, double y, int octaves, double gain = 0.5) const;
  double Fbm3(double x, double y, double z, int octaves, double gain = 0.5) const;
  double Fbm2PeriodicX(double x, double y, int period, int octaves, double gain = 0.5) const;

 private:
  int Hash(int ix) const { return perm_[ix & (kPeriod - 1)]; }
  float Value(int ix, int iy) const { return values_[Hash(Hash(ix) + iy)]; }
  float Value(int ix, int iy, int iz) const { return values_[Hash(Hash(Hash(ix) + iy) + iz)]; }
  double Interp2(int x0, int x1, int iy, double tx, double ty) const;

  std::array<uint16_t, kPeriod> perm_;
  std::array<float, kPeriod> values_;
};

}  // namespace stemmap
