#include "stemmap/core/fast_math.h"

#include <gtest/gtest.h>

namespace stemmap {
namespace {

TEST(ExpNeg, FollowsExpWithinItsStatedError) {
  double worst = 0.0;
  for (double x = 0.0; x < 20.0; x += 0.000731) {
    worst = std::max(worst, std::abs(ExpNeg(x) / std::exp(-x) - 1.0));
  }
  EXPECT_LT(worst, 8e-6);
  EXPECT_EQ(ExpNeg(0.0), 1.0);
  EXPECT_EQ(ExpNeg(-1.0), 1.0);  // clamped at zero, as the callers' max(x, 0) would
  EXPECT_EQ(ExpNeg(30.0), std::exp(-30.0));
}

TEST(FastAtan2, FollowsAtan2InEveryQuadrant) {
  double worst = 0.0;
  for (double a = -3.2; a < 3.2; a += 0.000917) {
    for (double r : {1e-6, 0.37, 1.0, 45.0}) {
      const double x = r * std::cos(a), y = r * std::sin(a);
      double e = std::abs(FastAtan2(y, x) - std::atan2(y, x));
      e = std::min(e, 2.0 * M_PI - e);  // ±π are the same direction
      worst = std::max(worst, e);
    }
  }
  EXPECT_LT(worst, 1e-7);
  EXPECT_EQ(FastAtan2(0.0, 0.0), 0.0);
  EXPECT_NEAR(FastAtan2(1.0, 0.0), M_PI / 2, 1e-12);
  EXPECT_NEAR(FastAtan2(0.0, -2.0), M_PI, 1e-12);
  EXPECT_NEAR(FastAtan2(-1.0, -1.0), -0.75 * M_PI, 1e-7);
  EXPECT_TRUE(std::isnan(FastAtan2(std::nan(""), 1.0)));
  EXPECT_TRUE(std::isnan(FastAtan2(1.0, std::nan(""))));
}

}  // namespace
}  // namespace stemmap
