#include "stemmap/track/plot_frame.h"

#include <gtest/gtest.h>

#include <cmath>

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
  const GroundFit fit = FitGround(GroundFitOptions(), pts);
  ASSERT_TRUE(fit.found);
  EXPECT_NEAR(fit.height_at_axis_m, -1.3, 0.01);
  EXPECT_NEAR(fit.slope_deg, 5.0, 0.3);
}

// Understory as the sparse points see it: the ground shows in gaps only, and leafy shrubs and
// sapling crowns, 0.2-1.2 m tall, cover most of the plot with denser points on their upper leaves
// than the ground has (the camera looks down on them). The ground is the floor under them all.
TEST(PlotFrame, GroundUnderUnderstory) {
  for (double cover : {0.5, 0.7, 0.85}) {
    for (double slope_deg : {0.0, 8.0}) {
      for (uint64_t seed : {11, 12}) {
        SCOPED_TRACE(::testing::Message()
                     << "cover " << cover << ", slope " << slope_deg << "°, seed " << seed);
        Rng rng(seed);
        const double g = std::tan(slope_deg * M_PI / 180.0);
        // Shrubs: discs 1-3 m across placed until they cover `cover` of the annulus (by sampling).
        std::vector<Eigen::Vector4d> shrubs;  // x, y, radius, height
        auto shrub_at = [&](double x, double y) -> const Eigen::Vector4d* {
          for (const Eigen::Vector4d& s : shrubs) {
            if (std::hypot(x - s.x(), y - s.y()) < s.z()) return &s;
          }
          return nullptr;
        };
        for (int tries = 0; tries < 4000; ++tries) {
          int covered = 0;
          for (int k = 0; k < 400; ++k) {
            const double a = 2 * M_PI * k / 400.0, r = 2 + 10 * ((k * 37) % 400) / 400.0;
            covered += shrub_at(r * std::cos(a), r * std::sin(a)) != nullptr;
          }
          if (covered >= cover * 400) break;
          const double a = rng.Uniform(0, 2 * M_PI), r = rng.Uniform(2, 12);
          shrubs.emplace_back(r * std::cos(a), r * std::sin(a), rng.Uniform(0.5, 1.5),
                              rng.Uniform(0.2, 1.2));
        }
        std::vector<Eigen::Vector3d> pts;
        for (int i = 0; i < 3000; ++i) {
          const double a = rng.Uniform(0, 2 * M_PI), r = rng.Uniform(2, 12);
          const double x = r * std::cos(a), y = r * std::sin(a);
          const double ground = -1.3 - g * x;
          const Eigen::Vector4d* s = shrub_at(x, y);
          if (s == nullptr) {
            if (i % 3 == 0) pts.emplace_back(x, y, ground + rng.Normal(0, 0.01));
          } else {
            // Mostly the upper leaves; now and then a leaf lower down.
            const double h = s->w() * (1 - 0.6 * std::pow(rng.Uniform(), 3));
            pts.emplace_back(x, y, ground + h);
          }
        }
        const GroundFit fit = FitGround(GroundFitOptions(), pts);
        ASSERT_TRUE(fit.found);
        EXPECT_NEAR(fit.height_at_axis_m, -1.3, 0.05);
        EXPECT_NEAR(fit.slope_deg, slope_deg, 1.0);
      }
    }
  }
}

TEST(PlotFrame, NoGroundInEmptyCloud) { EXPECT_FALSE(FitGround(GroundFitOptions(), {}).found); }

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
