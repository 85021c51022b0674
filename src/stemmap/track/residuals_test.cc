#include "stemmap/track/residuals.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "stemmap/camera/camera.h"

namespace stemmap::track {
namespace {

// Autodiff Jacobians against central differences of the same functor. Both cost functions are
// instantiated here (Ceres' GradientChecker hands Eigen objects across the library boundary,
// which breaks when the library was built with another Eigen alignment).
template <typename Functor, int kResiduals, int... kSizes>
void ExpectGradientsMatch(const Functor& functor, std::vector<double*> params) {
  ceres::AutoDiffCostFunction<Functor, kResiduals, kSizes...> autodiff(new Functor(functor));
  ceres::NumericDiffCostFunction<Functor, ceres::CENTRAL, kResiduals, kSizes...> numeric(
      new Functor(functor));
  constexpr int sizes[] = {kSizes...};
  std::vector<std::vector<double>> ja, jn;
  std::vector<double*> pa, pn;
  for (int size : sizes) {
    ja.emplace_back(kResiduals * size);
    jn.emplace_back(kResiduals * size);
  }
  for (size_t i = 0; i < ja.size(); ++i) {
    pa.push_back(ja[i].data());
    pn.push_back(jn[i].data());
  }
  double ra[kResiduals], rn[kResiduals];
  ASSERT_TRUE(autodiff.Evaluate(params.data(), ra, pa.data()));
  ASSERT_TRUE(numeric.Evaluate(params.data(), rn, pn.data()));
  for (int r = 0; r < kResiduals; ++r) EXPECT_NEAR(ra[r], rn[r], 1e-9);
  for (size_t b = 0; b < ja.size(); ++b) {
    for (size_t k = 0; k < ja[b].size(); ++k) {
      EXPECT_NEAR(ja[b][k], jn[b][k], 1e-5 * std::max(1.0, std::abs(ja[b][k])))
          << "block " << b << " entry " << k;
    }
  }
}

TEST(Residuals, ReprojectionGradient) {
  Eigen::Quaterniond q(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, -0.1).normalized()));
  Eigen::Vector3d c(0.9, 0.2, 0.01), x(2.0, 1.0, 5.0);
  double k = 1.02;
  ExpectGradientsMatch<ReprojectionError, 2, 4, 3, 3, 1>(
      ReprojectionError({0.1, -0.05}, 800.0), {q.coeffs().data(), c.data(), x.data(), &k});
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
  ExpectGradientsMatch<CirclePriorError, 2, 3>(CirclePriorError(0.99, 0.01, 0.01), {c.data()});
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
  ExpectGradientsMatch<MountPriorError, 3, 4, 3, 4>(
      MountPriorError(0.01), {off.coeffs().data(), c.data(), m.coeffs().data()});
}

// The pose-block adapters read [q, c] from one block and must agree with the split functors.
TEST(Residuals, PoseBlockAdaptersMatchTheSplitResiduals) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.1, 1.0, 0.2).normalized()));
  const Eigen::Vector3d c(0.95, 0.3, 0.02);
  Eigen::Vector3d x(2.0, 1.0, 5.0);
  const Eigen::Quaterniond m(Eigen::AngleAxisd(0.03, Eigen::Vector3d(1, -2, 1).normalized()));
  double pose[7];
  std::copy_n(q.coeffs().data(), 4, pose);
  std::copy_n(c.data(), 3, pose + 4);
  double k = 1.01;
  double a[3], b[3];
  ReprojectionError({0.1, -0.05}, 800.0)(q.coeffs().data(), c.data(), x.data(), &k, a);
  PoseReprojectionError({0.1, -0.05}, 800.0)(pose, x.data(), &k, b);
  EXPECT_EQ(a[0], b[0]);
  EXPECT_EQ(a[1], b[1]);
  CirclePriorError(0.99, 0.01, 0.02)(c.data(), a);
  PoseCirclePriorError(0.99, 0.01, 0.02)(pose, b);
  EXPECT_EQ(a[0], b[0]);
  EXPECT_EQ(a[1], b[1]);
  MountPriorError(0.01)(q.coeffs().data(), c.data(), m.coeffs().data(), a);
  PoseMountPriorError(0.01)(pose, m.coeffs().data(), b);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(a[i], b[i]);
  YawGaugeError()(c.data(), a);
  PoseYawGaugeError()(pose, b);
  EXPECT_EQ(a[0], b[0]);
  ExpectGradientsMatch<PoseReprojectionError, 2, 7, 3, 1>(
      PoseReprojectionError({0.1, -0.05}, 800.0), {pose, x.data(), &k});
}

// The hand-written derivatives against automatic differentiation of the same residual, for
// poses around the circle, a quaternion a little off unit length (as between manifold steps),
// and a point behind the camera.
void ExpectAnalyticReprojectionMatchesAutomatic(const RadialLens& lens);

// With and without a distorting lens (the `wide` preset's).
TEST(Residuals, AnalyticReprojectionMatchesAutomatic) {
  for (const RadialLens& lens : {RadialLens{}, RadialLens{-0.25, 0.07, -0.008}}) {
    SCOPED_TRACE(lens.k1);
    ExpectAnalyticReprojectionMatchesAutomatic(lens);
  }
}

// A lens's distortion does not scale with the focal length: the residual vanishes where the
// camera of focal length f k (the same k1-k3) images the point, which scaling the undistorted
// ray would miss by pixels near the edge of a wide lens.
TEST(Residuals, TheFocalScaleAppliesToWhatTheLensGives) {
  const PinholeCamera camera = PinholeCamera::FromLensHfov(960, 540, 100.0, -0.25, 0.07, -0.008);
  const double k = 1.007;  // focus breathing
  PinholeCamera refined = camera;
  refined.fx *= k;
  refined.fy *= k;
  const Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  const Eigen::Vector3d c = Eigen::Vector3d::Zero();
  const RadialLens lens{camera.k1, camera.k2, camera.k3};
  double largest_pinhole_px = 0.0;
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(0.0, 0.0, 5.0), Eigen::Vector3d(3.0, 1.0, 5.0),
                                   Eigen::Vector3d(-4.5, -1.5, 4.0)}) {
    const Eigen::Vector2d px = refined.ImageFromCam(x);
    const Eigen::Vector2d uv = camera.CamRayFromImage(px).head<2>();
    double r[2];
    ReprojectionError(uv, camera.fx, lens)(q.coeffs().data(), c.data(), x.data(), &k, r);
    EXPECT_NEAR(r[0], 0.0, 1e-6);
    EXPECT_NEAR(r[1], 0.0, 1e-6);
    ReprojectionError(uv, camera.fx)(q.coeffs().data(), c.data(), x.data(), &k, r);
    largest_pinhole_px = std::max(largest_pinhole_px, std::hypot(r[0], r[1]));
  }
  EXPECT_GT(largest_pinhole_px, 1.0);
}

void ExpectAnalyticReprojectionMatchesAutomatic(const RadialLens& lens) {
  const Eigen::Vector2d uv(0.1, -0.05);
  ceres::AutoDiffCostFunction<PoseReprojectionError, 2, 7, 3, 1> automatic(
      new PoseReprojectionError(uv, 800.0, lens));
  PoseReprojectionCost analytic(uv, 800.0, lens);
  int behind = 0;
  struct Case {
    double angle, norm;
    Eigen::Vector3d x;
  };
  for (const Case& t : {Case{0.3, 1.0, {2.0, 1.0, 5.0}}, Case{-2.1, 1.0 + 1e-6, {-4.0, 3.0, 1.0}},
                        Case{1.2, 1.0, {0.9, 0.2, -4.0}}}) {
    const Eigen::Quaterniond q(
        Eigen::AngleAxisd(t.angle, Eigen::Vector3d(0.2, 1.0, -0.1).normalized()));
    double pose[7];
    for (int i = 0; i < 4; ++i) pose[i] = q.coeffs()[i] * t.norm;
    pose[4] = std::cos(t.angle), pose[5] = std::sin(t.angle), pose[6] = 0.01;
    Eigen::Vector3d x = t.x;
    double k = 1.02;
    behind += (q * (x - Eigen::Vector3d(pose[4], pose[5], pose[6]))).z() < 0;
    const double* params[] = {pose, x.data(), &k};
    double ra[2], rb[2], ja[3][21], jb[3][21];
    double* pa[] = {ja[0], ja[1], ja[2]};
    double* pb[] = {jb[0], jb[1], jb[2]};
    ASSERT_TRUE(automatic.Evaluate(params, ra, pa));
    ASSERT_TRUE(analytic.Evaluate(params, rb, pb));
    for (int r = 0; r < 2; ++r) EXPECT_NEAR(ra[r], rb[r], 1e-9 * std::max(1.0, std::abs(ra[r])));
    const int sizes[] = {14, 6, 2};
    for (int b = 0; b < 3; ++b) {
      for (int i = 0; i < sizes[b]; ++i) {
        EXPECT_NEAR(ja[b][i], jb[b][i], 1e-9 * std::max(1.0, std::abs(ja[b][i])))
            << "block " << b << " entry " << i;
      }
    }
    // Residuals alone, without Jacobians.
    ASSERT_TRUE(analytic.Evaluate(params, rb, nullptr));
    EXPECT_NEAR(ra[0], rb[0], 1e-9 * std::max(1.0, std::abs(ra[0])));
  }
  EXPECT_GE(behind, 1);  // both branches are checked
  EXPECT_LT(behind, 3);
}

}  // namespace
}  // namespace stemmap::track
