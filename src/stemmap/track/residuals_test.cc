#include "stemmap/track/residuals.h"

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <memory>

namespace stemmap::track {
namespace {

// Autodiff against central differences, on the quaternion manifold where one is used.
void ExpectGradientsMatch(ceres::CostFunction* cost, std::vector<double*> params,
                          std::vector<const ceres::Manifold*> manifolds) {
  std::unique_ptr<ceres::CostFunction> owned(cost);
  ceres::NumericDiffOptions nd;
  ceres::GradientChecker checker(cost, &manifolds, nd);
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(params.data(), 1e-7, &results)) << results.error_log;
}

TEST(Residuals, ReprojectionGradient) {
  Eigen::Quaterniond q(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, -0.1).normalized()));
  Eigen::Vector3d c(0.9, 0.2, 0.01), x(2.0, 1.0, 5.0);
  double k = 1.02;
  ceres::EigenQuaternionManifold qm;
  ExpectGradientsMatch(ReprojectionError::Create({0.1, -0.05}, 800.0),
                       {q.coeffs().data(), c.data(), x.data(), &k},
                       {&qm, nullptr, nullptr, nullptr});
}

TEST(Residuals, ReprojectionIsZeroAtTheProjection) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()));
  const Eigen::Vector3d c(1, 0, 0), x(1.5, 1, 5);
  const Eigen::Vector3d p = q * (x - c);
  ReprojectionError e(p.head<2>() / p.z(), 1000.0);
  double r[2];
  const double k = 1.0;
  e(q.coeffs().data(), c.data(), x.data(), &k, r);
  EXPECT_NEAR(r[0], 0.0, 1e-9);
  EXPECT_NEAR(r[1], 0.0, 1e-9);
}

TEST(Residuals, CirclePriorValuesAndGradient) {
  Eigen::Vector3d c(0.6, 0.8, 0.02);  // radius 1.0, 2 cm above the plane
  CirclePriorError e(0.99, 0.01, 0.01);
  double r[2];
  e(c.data(), r);
  EXPECT_NEAR(r[0], 1.0, 1e-6);
  EXPECT_NEAR(r[1], 2.0, 1e-9);
  ExpectGradientsMatch(CirclePriorError::Create(0.99, 0.01, 0.01), {c.data()}, {nullptr});
}

TEST(Residuals, MountPriorZeroOnTheRigAndGradient) {
  const double phi = 0.7;
  const Eigen::Quaterniond mount(Eigen::AngleAxisd(0.05, Eigen::Vector3d(1, 2, 3).normalized()));
  const Eigen::Quaterniond world_from_cam =
      Eigen::Quaterniond(Eigen::AngleAxisd(phi, Eigen::Vector3d::UnitZ())) * mount;
  Eigen::Quaterniond q = world_from_cam.conjugate();
  Eigen::Quaterniond m = mount;
  Eigen::Vector3d c(std::cos(phi), std::sin(phi), 0.0);
  MountPriorError e(0.01);
  double r[3];
  e(q.coeffs().data(), c.data(), m.coeffs().data(), r);
  for (double v : r) EXPECT_NEAR(v, 0.0, 1e-9);
  // Off the rig by 0.02 rad about z: the residual reads 2 sigma.
  Eigen::Quaterniond off =
      (Eigen::Quaterniond(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ())) * world_from_cam)
          .conjugate();
  e(off.coeffs().data(), c.data(), m.coeffs().data(), r);
  EXPECT_NEAR(Eigen::Vector3d(r[0], r[1], r[2]).norm(), 2.0, 1e-6);
  ceres::EigenQuaternionManifold qm;
  ExpectGradientsMatch(MountPriorError::Create(0.01),
                       {off.coeffs().data(), c.data(), m.coeffs().data()}, {&qm, nullptr, &qm});
}

}  // namespace
}  // namespace stemmap::track
