#include "stemmap/core/exp_table.h"

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

}  // namespace
}  // namespace stemmap
