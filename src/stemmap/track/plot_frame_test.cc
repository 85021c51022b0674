#include "stemmap/track/plot_frame.h"

#include <gtest/gtest.h>

#include "stemmap/core/rng.h"

namespace stemmap::track {
namespace {

TEST(PlotFrame, GroundPlaneThroughClutter) {
  Rng rng(3);
  std::vector<Eigen::Vector3d> pts;
  // Ground 1.3 m below the camera circle, sloping 5° toward +x; shrubs above it.
  const double g = std::tan(5.0 * M_PI / 180.0);
  for (int i = 0; i < 600; ++i) {
    const double a = rng.Uniform(0, 2 * M_PI), r = rng.Uniform(3, 11);
    const double x = r * std::cos(a), y = r * std::sin(a);
    double z = -1.3 - g * x + rng.Normal(0, 0.01);
    if (i % 4 == 0) z += rng.Uniform(0.2, 1.0);  // not ground
    pts.emplace_back(x, y, z);
  }
  const GroundFit fit = FitGround(pts, 2.0, 12.0, 0.05, 1);
  ASSERT_TRUE(fit.found);
  EXPECT_NEAR(fit.height_at_axis_m, -1.3, 0.01);
  EXPECT_NEAR(fit.slope_deg, 5.0, 0.3);
}

TEST(PlotFrame, NoGroundInEmptyCloud) { EXPECT_FALSE(FitGround({}, 2.0, 12.0, 0.05, 1).found); }

TEST(PlotFrame, OriginOnTheGroundAndXAlongTheFirstView) {
  const Eigen::Vector3d up = Eigen::Vector3d(0.01, 0, 1).normalized();
  const Rigid3d t = PlotFromAxis(up, -1.3, Eigen::Vector3d(0, 1, 0.05));
  EXPECT_LT((t * Eigen::Vector3d(0, 0, -1.3)).norm(), 1e-12);
  EXPECT_LT((t.rotation * up - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  const Eigen::Vector3d fwd = t.rotation * Eigen::Vector3d(0, 1, 0.05);
  EXPECT_NEAR(fwd.y(), 0.0, 1e-12);
  EXPECT_GT(fwd.x(), 0.0);
}

}  // namespace
}  // namespace stemmap::track
