#include "stemmap/sim/ground.h"

#include <gtest/gtest.h>

#include <cmath>

namespace stemmap::sim {
namespace {

// The ground's height is zero at the plot origin, its slopes agree with its heights and stay
// within the bound the ray march relies on, and its normals point up.
TEST(Ground, HeightsSlopesAndBoundAgree) {
  const Ground g(6.0, 0.8, 0.12, 3.0, 42);
  EXPECT_NEAR(g.Height(0.0, 0.0), 0.0, 1e-12);
  const double h = 0.01;
  double worst_slope = 0.0, worst_gradient_error = 0.0;
  for (double x = -20.0; x <= 20.0; x += 0.537) {
    for (double y = -20.0; y <= 20.0; y += 0.611) {
      const Eigen::Vector2d fd((g.Height(x + h, y) - g.Height(x - h, y)) / (2 * h),
                               (g.Height(x, y + h) - g.Height(x, y - h)) / (2 * h));
      const Eigen::Vector2d grad = g.Gradient(x, y);
      worst_gradient_error = std::max(worst_gradient_error, (grad - fd).norm());
      worst_slope = std::max(worst_slope, fd.norm());
      EXPECT_GT(g.Normal(x, y).z(), 0.9);
    }
  }
  // The gradient is read smoothly across the 0.1-m cells: it differs from the cell's own slope by
  // a share of the bumps' curvature, never by the plane's 10 %.
  EXPECT_LT(worst_gradient_error, 0.05);
  EXPECT_LE(worst_slope, g.LipschitzBound());
  EXPECT_GT(worst_slope, std::tan(6.0 * M_PI / 180.0) * 0.9);
  // Within the bumps' slab around the plane.
  for (double x : {-30.0, -3.3, 0.7, 11.0, 45.0}) {
    EXPECT_LE(std::abs(g.Height(x, 2.0) - g.PlaneHeight(x, 2.0)), g.BumpBound());
  }
}

}  // namespace
}  // namespace stemmap::sim
