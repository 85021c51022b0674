#include "stemmap/core/noise.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "stemmap/core/rng.h"

namespace stemmap {
namespace {

TEST(ValueNoise, DeterministicBoundedAndSeedDependent) {
  ValueNoise a(7), b(7), c(8);
  double max_abs = 0.0, diff = 0.0;
  for (int i = 0; i < 1000; ++i) {
    const double x = i * 0.137, y = i * 0.071;
    EXPECT_EQ(a.Noise2(x, y), b.Noise2(x, y));
    max_abs = std::max(max_abs, std::abs(a.Fbm3(x, y, 0.3 * x, 4)));
    diff += std::abs(a.Noise2(x, y) - c.Noise2(x, y));
  }
  EXPECT_LE(max_abs, 1.0);
  EXPECT_GT(diff, 10.0);
}

TEST(ValueNoise, ContinuousAcrossLatticeCells) {
  ValueNoise n(3);
  for (double x = 0.5; x < 20; x += 1.0) {
    EXPECT_NEAR(n.Noise2(x - 1e-7, 0.3), n.Noise2(x + 1e-7, 0.3), 1e-5);
    EXPECT_NEAR(n.Noise2(std::floor(x) - 1e-7, 0.3), n.Noise2(std::floor(x) + 1e-7, 0.3), 1e-5);
  }
}

TEST(ValueNoise, PeriodicInX) {
  ValueNoise n(5);
  for (double y = 0.1; y < 5; y += 0.7) {
    EXPECT_NEAR(n.Noise2PeriodicX(0.3, y, 7), n.Noise2PeriodicX(7.3, y, 7), 1e-12);
    EXPECT_NEAR(n.Fbm2PeriodicX(6.9999999, y, 7, 3), n.Fbm2PeriodicX(-1e-7, y, 7, 3), 1e-5);
  }
}

// The renderer skips reading the noise where even its largest value could not matter.
TEST(ValueNoise, NeverExceedsItsLargestLatticeValue) {
  ValueNoise n(11);
  double largest = -1.0;
  for (int i = 0; i < 20000; ++i) {
    const double x = i * 0.0371, y = i * 0.0173, z = i * 0.0291;
    largest = std::max({largest, n.Noise2(x, y), n.Noise3(x, y, z)});
  }
  EXPECT_LE(largest, n.MaxValue());
  EXPECT_GT(largest, n.MaxValue() - 0.05);  // the bound is the lattice's, not a loose 1
  EXPECT_LT(n.MaxValue(), 1.0);
}

TEST(Rng, SameSeedSameStreamAndSaneMoments) {
  Rng a(42), b(42);
  double sum = 0, sum2 = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(a.NextU64(), b.NextU64());
    const double v = a.Normal();
    b.Normal();
    sum += v;
    sum2 += v * v;
  }
  EXPECT_NEAR(sum / n, 0.0, 0.03);
  EXPECT_NEAR(sum2 / n, 1.0, 0.05);
}

}  // namespace
}  // namespace stemmap
