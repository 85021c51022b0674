#include "stemmap/stems/tangent.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "stemmap/core/rng.h"

namespace stemmap::stems {
namespace {

// Tangent lines to a circle from cameras along the arm's arc, a few of them clipped by an
// occluder: the fit recovers centre and radius and ignores the clipped rays.
TEST(Tangent, CircleFromTangentRays) {
  const Eigen::Vector2d centre(5.0, 1.0);
  const double radius = 0.2;
  Rng rng(3);
  std::vector<Eigen::Vector2d> normals, origins;
  for (int k = 0; k < 30; ++k) {
    const double phi = -0.3 + 0.6 * k / 29.0;
    const Eigen::Vector2d c(std::cos(phi), std::sin(phi));
    const Eigen::Vector2d to = centre - c;
    const double d = to.norm(), alpha = std::asin(radius / d);
    for (int side : {-1, 1}) {
      // Edge ray direction, with 0.3 mrad of edge noise; every tenth ray clipped by 2 cm.
      double a = side * alpha + rng.Normal(0, 3e-4);
      if (k % 10 == 0 && side == 1) a -= 0.02 / d;
      const Eigen::Vector2d dir = Eigen::Rotation2Dd(a) * (to / d);
      Eigen::Vector2d n(-dir.y(), dir.x());
      if (n.dot(centre - c) < 0) n = -n;
      normals.push_back(n);
      origins.push_back(c);
    }
  }
  Eigen::Vector2d fitted;
  double r = 0, r_sd = 0, rms = 0;
  ASSERT_TRUE(SolveTangentCircle(normals, origins, 0.004, &fitted, &r, &r_sd, &rms, nullptr));
  EXPECT_NEAR(r, radius, 0.002);
  EXPECT_NEAR((fitted - centre).norm(), 0.0, 0.03);
  EXPECT_GT(r_sd, 0.0);
  EXPECT_LT(r_sd, 0.003);
}

// Edge points of a leaning silhouette with 0.3 px of noise and two bands on a neighbour's edge.
TEST(Tangent, EdgeLineIgnoresStrayBands) {
  Rng rng(5);
  std::vector<double> y, x;
  for (int i = 0; i < 15; ++i) {
    y.push_back(400 + 9 * i);
    x.push_back(700 + 0.05 * (y.back() - 463) + rng.Normal(0, 0.3));
  }
  x[2] += 25;
  x[11] -= 14;
  double x0 = 0;
  ASSERT_TRUE(FitEdgeLine(y, x, 463, 8, &x0));
  EXPECT_NEAR(x0, 700.0, 0.3);
  // Too few points, or a line far from vertical, is no silhouette.
  EXPECT_FALSE(FitEdgeLine(y, x, 463, 16, &x0));
  std::vector<double> slanted(x.size());
  for (size_t i = 0; i < x.size(); ++i) slanted[i] = 700 + 0.4 * (y[i] - 463);
  EXPECT_FALSE(FitEdgeLine(y, slanted, 463, 8, &x0));
}

// Rays from a 2-cm stretch of the arm barely fix the depth: the prior on the centre holds it,
// while the rays still set the bearing and the radius.
TEST(Tangent, CentrePriorHoldsTheDepth) {
  const Eigen::Vector2d centre(10.0, 0.0);
  const double radius = 0.18;
  Rng rng(7);
  std::vector<Eigen::Vector2d> normals, origins;
  for (int k = 0; k < 12; ++k) {
    const double phi = -0.01 + 0.02 * k / 11.0;
    const Eigen::Vector2d c(std::cos(phi), std::sin(phi));
    const Eigen::Vector2d to = centre - c;
    const double d = to.norm(), alpha = std::asin(radius / d);
    for (int side : {-1, 1}) {
      const Eigen::Vector2d dir = Eigen::Rotation2Dd(side * alpha + rng.Normal(0, 3e-4)) * (to / d);
      Eigen::Vector2d n(-dir.y(), dir.x());
      if (n.dot(centre - c) < 0) n = -n;
      normals.push_back(n);
      origins.push_back(c);
    }
  }
  const CentrePrior prior{Eigen::Vector2d(10.3, 0.02), 0.5, 0.004};
  Eigen::Vector2d fitted;
  double r = 0, r_sd = 0, rms = 0;
  ASSERT_TRUE(
      SolveTangentCircle(normals, origins, 0.004, &fitted, &r, &r_sd, &rms, nullptr, &prior));
  EXPECT_NEAR(fitted.y(), 0.0, 0.01);                // bearing from the rays
  EXPECT_NEAR(fitted.x(), 10.0, 0.35);               // depth between the rays' and the prior's
  EXPECT_NEAR(r / fitted.x(), radius / 10.0, 2e-4);  // angular size from the rays
}

TEST(Tangent, DegenerateSystems) {
  Eigen::Vector2d c;
  double r, sd, rms;
  EXPECT_FALSE(
      SolveTangentCircle({{1, 0}, {0, 1}}, {{0, 0}, {0, 0}}, 0.004, &c, &r, &sd, &rms, nullptr));
}

}  // namespace
}  // namespace stemmap::stems
