#include "stemmap/stems/tangent.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <Eigen/Geometry>
#include <functional>
#include <utility>

#include "stemmap/camera/camera.h"
#include "stemmap/core/error.h"
#include "stemmap/core/pose.h"
#include "stemmap/core/rng.h"
#include "stemmap/stems/bark_depth.h"
#include "stemmap/stems/silhouette.h"
#include "stemmap/stems/test_scene.h"

namespace stemmap::stems {
namespace {

// A finished fit: its circle, how tight, on how many silhouettes and views with both sides.
TangentFit FitOf(const Eigen::Vector2d& centre, double radius_m, double rms_m, int rays,
                 int two_sided_views) {
  TangentFit f;
  f.ok = true;
  f.centre = centre;
  f.radius_m = radius_m;
  f.rms_m = rms_m;
  f.rays = rays;
  f.two_sided_views = two_sided_views;
  return f;
}

// Rays tangent to the circle (centre, radius) from n camera centres on the unit circle at
// angles phi0..phi1, both sides, with noise_rad of edge noise; clip_m(k, side) bites that many
// metres off a ray at the stem (an occluder).
struct Rays {
  std::vector<Eigen::Vector2d> normals, origins;
};

Rays TangentRaysFromArc(const Eigen::Vector2d& centre, double radius, double phi0, double phi1,
                        int n, double noise_rad, Rng& rng,
                        const std::function<double(int, int)>& clip_m = nullptr) {
  Rays rays;
  for (int k = 0; k < n; ++k) {
    const double phi = phi0 + (phi1 - phi0) * k / (n - 1.0);
    const Eigen::Vector2d c(std::cos(phi), std::sin(phi));
    const Eigen::Vector2d to = centre - c;
    const double d = to.norm(), alpha = std::asin(radius / d);
    for (int side : {-1, 1}) {
      double a = side * alpha + rng.Normal(0, noise_rad);
      if (clip_m) a -= clip_m(k, side) / d;
      const Eigen::Vector2d dir = Eigen::Rotation2Dd(a) * (to / d);
      Eigen::Vector2d nrm(-dir.y(), dir.x());
      if (nrm.dot(centre - c) < 0) nrm = -nrm;
      rays.normals.push_back(nrm);
      rays.origins.push_back(c);
    }
  }
  return rays;
}

// Tangent lines to a circle from cameras along the arm's arc, a few of them clipped by an
// occluder: the fit recovers centre and radius and ignores the clipped rays.
TEST(Tangent, CircleFromTangentRays) {
  const Eigen::Vector2d centre(5.0, 1.0);
  const double radius = 0.2;
  Rng rng(3);
  // 0.3 mrad of edge noise; every tenth ray clipped by 2 cm.
  const auto [normals, origins] =
      TangentRaysFromArc(centre, radius, -0.3, 0.3, 30, 3e-4, rng,
                         [](int k, int side) { return k % 10 == 0 && side == 1 ? 0.02 : 0.0; });
  Eigen::Vector2d fitted;
  double r = 0, r_sd = 0, rms = 0;
  ASSERT_TRUE(SolveTangentCircle(normals, origins, 0.004, &fitted, &r, &r_sd, &rms, nullptr));
  EXPECT_NEAR(r, radius, 0.002);
  EXPECT_NEAR((fitted - centre).norm(), 0.0, 0.03);
  EXPECT_GT(r_sd, 0.0);
  EXPECT_LT(r_sd, 0.003);
}

// A third of one side's edges caught a shrub 3 cm beyond the stem (rays bent outward): Huber
// weights alone would still widen the circle by about 2 mm; the Cauchy stage does not.
TEST(Tangent, FarOffRaysDoNotWidenTheCircle) {
  const Eigen::Vector2d centre(8.0, -1.0);
  const double radius = 0.12;
  Rng rng(11);
  const auto [normals, origins] =
      TangentRaysFromArc(centre, radius, -0.4, 0.2, 36, 3e-4, rng,
                         [](int k, int side) { return k % 3 == 0 && side == 1 ? -0.03 : 0.0; });
  Eigen::Vector2d fitted;
  double r = 0, r_sd = 0, rms = 0;
  ASSERT_TRUE(SolveTangentCircle(normals, origins, 0.004, &fitted, &r, &r_sd, &rms, nullptr));
  EXPECT_NEAR(r, radius, 0.0015);
  EXPECT_NEAR((fitted - centre).norm(), 0.0, 0.02);
  double r_huber = 0;
  ASSERT_TRUE(SolveTangentCircle(normals, origins, 0.004, &fitted, &r_huber, &r_sd, &rms, nullptr,
                                 nullptr, /*redescend=*/false));
  EXPECT_GT(r_huber - radius, 0.0015);
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
  double x0 = 0, scatter_px = 0;
  ASSERT_TRUE(FitEdgeLine(y, x, 463, 8, &x0, &scatter_px));
  EXPECT_NEAR(x0, 700.0, 0.3);
  // The bands' scatter about the line is their noise's, whatever the stray bands.
  EXPECT_NEAR(scatter_px, 0.3, 0.15);
  // A leaf clump's outline: jagged by several pixels from band to band.
  std::vector<double> jagged(x.size());
  for (size_t i = 0; i < x.size(); ++i) jagged[i] = 700 + rng.Normal(0, 4.0);
  ASSERT_TRUE(FitEdgeLine(y, jagged, 463, 8, &x0, &scatter_px));
  EXPECT_GT(scatter_px, 2.0);
  // Too few points, or a line far from vertical, is no silhouette.
  EXPECT_FALSE(FitEdgeLine(y, x, 463, 16, &x0));
  std::vector<double> slanted(x.size());
  for (size_t i = 0; i < x.size(); ++i) slanted[i] = 700 + 0.4 * (y[i] - 463);
  EXPECT_FALSE(FitEdgeLine(y, slanted, 463, 8, &x0));
}

// Rays from a 2-cm stretch of the arm barely fix the depth: the prior on the centre holds it,
// while the rays still set the bearing and the radius.
TEST(Tangent, SilhouetteCrossingSkipsShortSpikesInsideTheStem) {
  // Low inside the stem (samples 0-29) but for a 2-sample spike at 10-11, high from 30 on.
  std::vector<double> profile(50, 2.0);
  profile[10] = profile[11] = 30.0;
  for (int i = 30; i < 50; ++i) profile[i] = 40.0;
  profile[29] = 12.0;
  double x = 0;
  ASSERT_TRUE(FirstSustainedCrossing(profile, 0, 1, 21.0, 5, &x));
  EXPECT_NEAR(x, 29 + (21.0 - 12.0) / (40.0 - 12.0), 1e-9);
  // Leftward from 25 only the spike rises: no silhouette on that side.
  EXPECT_FALSE(FirstSustainedCrossing(profile, 25, -1, 21.0, 5, &x));
  // A one-sample run takes the spike; a profile that never rises has no crossing.
  ASSERT_TRUE(FirstSustainedCrossing(profile, 0, 1, 21.0, 1, &x));
  EXPECT_LT(x, 10.0);
  EXPECT_FALSE(FirstSustainedCrossing(std::vector<double>(20, 1.0), 5, 1, 21.0, 5, &x));
}

TEST(Tangent, CentrePriorHoldsTheDepth) {
  const Eigen::Vector2d centre(10.0, 0.0);
  const double radius = 0.18;
  Rng rng(7);
  const auto [normals, origins] = TangentRaysFromArc(centre, radius, -0.01, 0.01, 12, 3e-4, rng);
  const CentrePrior prior{Eigen::Vector2d(10.3, 0.02), 0.5, 0.004};
  Eigen::Vector2d fitted;
  double r = 0, r_sd = 0, rms = 0;
  ASSERT_TRUE(
      SolveTangentCircle(normals, origins, 0.004, &fitted, &r, &r_sd, &rms, nullptr, &prior));
  EXPECT_NEAR(fitted.y(), 0.0, 0.01);                // bearing from the rays
  EXPECT_NEAR(fitted.x(), 10.0, 0.35);               // depth between the rays' and the prior's
  EXPECT_NEAR(r / fitted.x(), radius / 10.0, 2e-4);  // angular size from the rays
}

// Rays of one side only (the other hidden behind a nearer stem) say where that side is, not how
// wide the stem is: a radius prior holds the width, and the rays then place the centre.
TEST(Tangent, RadiusPriorHoldsTheWidthOfAOneSidedStem) {
  const Eigen::Vector2d centre(8.5, 3.0);
  const double radius = 0.08;
  Rng rng(9);
  const Rays both = TangentRaysFromArc(centre, radius, 0.0, 0.6, 24, 3e-4, rng);
  Rays left;  // every other ray: one side
  for (size_t i = 0; i < both.normals.size(); i += 2) {
    left.normals.push_back(both.normals[i]);
    left.origins.push_back(both.origins[i]);
  }
  CentrePrior prior{Eigen::Vector2d(8.7, 3.05), 0.5, 0.004};
  prior.radius_m = 0.07;  // the cloud's width, a little small
  prior.radius_sigma_m = 0.0004;
  Eigen::Vector2d fitted;
  double r = 0, r_sd = 0, rms = 0;
  ASSERT_TRUE(SolveTangentCircle(left.normals, left.origins, 0.004, &fitted, &r, &r_sd, &rms,
                                 nullptr, &prior));
  EXPECT_NEAR(r, 0.07, 0.002);
  // The visible side stays where the rays put it: the centre moves in by the width's error.
  const Eigen::Vector2d across = Eigen::Vector2d(-centre.y(), centre.x()).normalized();
  EXPECT_LT(std::abs(across.dot(fitted - centre)), 0.03);
  EXPECT_LT((fitted - centre).norm(), 0.15);
}

// A stem right behind a nearer one: its left side seen only from one end of the arm, its right
// side only from the other. Each side's rays fix where that side is; range and width trade
// along the line of sight. The face's range (here 4 cm off, as the cloud's median gives it) holds
// the range, and the width follows to a few millimetres (here 4 mm, a tenth of the face's error:
// the arm's ends see the sides from 0.2-0.45 rad off the stem's bearing).
TEST(Tangent, TheFacesRangeHoldsAStemSeenOneSideAtATime) {
  const Eigen::Vector2d centre(8.0, 0.0);
  const double radius = 0.2;
  Rng rng(4);
  Rays apart;
  const Rays one_end = TangentRaysFromArc(centre, radius, 0.2, 0.45, 10, 5e-4, rng);
  const Rays other_end = TangentRaysFromArc(centre, radius, -0.45, -0.2, 10, 5e-4, rng);
  for (size_t i = 0; i < one_end.normals.size(); i += 2) {  // side -1 from one end
    apart.normals.push_back(one_end.normals[i]);
    apart.origins.push_back(one_end.origins[i]);
    apart.normals.push_back(other_end.normals[i + 1]);  // side +1 from the other
    apart.origins.push_back(other_end.origins[i + 1]);
  }
  CentrePrior prior{Eigen::Vector2d(8.3, 0.0), 0.5, 0.004};
  prior.face_bearing = Eigen::Vector2d::UnitX();
  prior.face_range_m = centre.x() - radius + 0.04;
  prior.face_sigma_m = 0.05;
  Eigen::Vector2d fitted;
  double r = 0, r_sd = 0, rms = 0;
  ASSERT_TRUE(SolveTangentCircle(apart.normals, apart.origins, 0.004, &fitted, &r, &r_sd, &rms,
                                 nullptr, &prior));
  EXPECT_NEAR(r, radius, 0.005);
  EXPECT_NEAR(fitted.x(), centre.x(), 0.06);
  EXPECT_NEAR(fitted.y(), centre.y(), 0.01);
  // The face's row is a prior, not a constraint: it gives way to the rays by its sigma.
  EXPECT_NEAR(fitted.x() - r, prior.face_range_m, 0.05);
}

// A 44-cm stem 9 m out, 1.2 degrees off the bearing of a 36.6-cm one 5 m out, seen as a 12.8-cm
// sliver at its far side: the nearer stem covers its right side (image right) in most views, and
// where the sliver puts that side, views see the stem's own bark. The widest circle that keeps
// that side hidden reaches past the true one; a stem with nothing in front hides no side.
TEST(Tangent, TheWidestCircleWithASideHiddenBoundsAStemSeenAsASliver) {
  const PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 67.0);
  const RenderedStem scene = RenderStems({}, false, false, Texture::kRegular, camera);
  const std::vector<Eigen::Vector3d> nearer = {{5.0, 0.0, 0.183}};
  const TangentOptions o;
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray, &nearer};
  const double a = 1.2 * M_PI / 180;
  const Eigen::Vector2d truth(9.0 * std::cos(a), 9.0 * std::sin(a));
  const double true_radius = 0.22, seen_radius = 0.064;
  // The sliver: the true circle's left side, its face where the true one's is.
  const Eigen::Vector2d u = truth.normalized(), left(-u.y(), u.x());
  const Eigen::Vector2d sliver = truth + (true_radius - seen_radius) * (left - u);
  EXPECT_GE(ViewsShowingSide(o, views, sliver, seen_radius, 1, 1.3), 3);
  const double widest = WidestRadiusWithSideHidden(o, views, sliver, seen_radius, 1, 1.3, 0.6);
  EXPECT_GT(widest, true_radius);
  EXPECT_LT(widest, 0.6);
  EXPECT_LT((GrownHoldingFace(sliver, seen_radius, 1, true_radius) - truth).norm(), 0.01);
  const std::vector<Eigen::Vector3d> none;
  const TangentViews open{&scene.camera, &scene.keyframes, &scene.gray, &none};
  EXPECT_EQ(WidestRadiusWithSideHidden(o, open, sliver, seen_radius, 1, 1.3, 0.6), seen_radius);
}

// The fit starts from a centre 0.3 m too far and a radius 2 cm small, as the cloud gives them.
TEST(Tangent, FitsARenderedStem) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.15;
  for (bool textured : {false, true}) {
    SCOPED_TRACE(textured ? "textured background" : "plain sky");
    const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}}, textured);
    const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
    const Eigen::Vector2d start = centre * (1.0 + 0.3 / centre.norm());
    const TangentFit fit =
        FitTangentRays(TangentOptions().ForImageScale(640.0 / 960.0), views, start, 0.13, 1.37);
    ASSERT_TRUE(fit.ok);
    // One pixel is 12 mm at the stem here (640-px images, aliased edges): a third of a pixel.
    EXPECT_NEAR(fit.radius_m, radius, 0.005);
    EXPECT_LT((fit.centre - centre).norm(), 0.06);
    EXPECT_GT(fit.views, 10);
    EXPECT_EQ(fit.hidden_sides, 0);
    EXPECT_EQ(fit.open_views, fit.tried_views);
  }
}

// Each side of a stem in plain view shows where its circle predicts it in the views the fit used;
// against a plain sky, a circle where no stem stands shows none.
TEST(Tangent, SideViewsAtCountsEachSideWhereTheCirclePredictsIt) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.15;
  const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}}, false);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  const TangentOptions o = TangentOptions().ForImageScale(640.0 / 960.0);
  const TangentFit fit = FitTangentRays(o, views, centre, radius, 1.37);
  ASSERT_TRUE(fit.ok);
  const std::array<int, 2> sides = SideViewsAt(o, views, centre, radius, 1.37);
  EXPECT_GE(sides[0], fit.views - 1);
  EXPECT_GE(sides[1], fit.views - 1);
  const Eigen::Vector2d beside = centre + Eigen::Vector2d(0.0, 1.0);
  EXPECT_EQ(SideViewsAt(o, views, beside, radius, 1.37), (std::array<int, 2>{0, 0}));
}

// A stem the arm passes close by (its bark 0.8 m from the camera), measured a little above the
// camera (a ground estimate too low, or a stem downhill): seen that close, the bands within
// 0.35 m of breast height reach beyond the picture's top, and the silhouettes rest on the bands
// it holds.
TEST(Tangent, FitsANearStemWhoseBandsReachBeyondThePicture) {
  const Eigen::Vector2d centre(1.92, 0.2);
  const double radius = 0.12;
  const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}}, true);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  for (const double breast_z : {1.3, 1.55}) {
    SCOPED_TRACE(::testing::Message() << "breast height at z " << breast_z);
    const TangentFit fit =
        FitTangentRays(TangentOptions().ForImageScale(640.0 / 960.0), views, centre, 0.1, breast_z);
    ASSERT_TRUE(fit.ok);
    // Within 1.5 cm (a near stem's fit from a narrow start comes out 0.7-1 cm narrow here); when
    // every band counted, out of the picture or not, the higher breast height read 4.4 cm.
    EXPECT_NEAR(fit.radius_m, radius, 0.015);
    EXPECT_LT((fit.centre - centre).norm(), 0.03);
    EXPECT_GE(fit.two_sided_views, 3);
  }
}

// A stem a metre from the arm spans much of the picture, and its edge search, wider still, did
// not fit the picture in most views: those views gave no silhouette, and the few left let a
// narrower circle win. The search now stops at the picture's borders, so every view that tries
// the stem gives the side it shows. Swept over the distance and the cloud's width (the start).
TEST(Tangent, ANearStemSeenLargeGivesSilhouettesInEveryViewThatTriesIt) {
  const PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 67.0);
  const double radius = 0.156;
  for (const double distance : {1.74, 2.0, 2.4}) {
    const Eigen::Vector2d centre(distance, 0.2);
    const RenderedStem scene =
        RenderStems({{centre.x(), centre.y(), radius}}, true, false, Texture::kRegular, camera);
    const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
    for (const double start : {0.137, 0.156, 0.17}) {
      SCOPED_TRACE(::testing::Message() << distance << " m, start r " << start);
      const TangentFit fit = FitTangentRays(TangentOptions(), views, centre, start, 1.37);
      ASSERT_TRUE(fit.ok);
      // Before, 7-14 of the 13-18 views tried gave a silhouette; the views counted are the
      // chosen fit's, and two of one start's may drop out in its rounds.
      EXPECT_GE(fit.views, fit.tried_views - 2);
      // Within 0.9 cm of DBH here (4.6 cm narrow before ANearStemsFitDoesNotHangOnItsStart's
      // depth steps, 7.8 cm before the search stopped at the picture's borders).
      EXPECT_NEAR(fit.radius_m, radius, 0.006);
    }
  }
}

// Depth steps come only where the neighbour's baseline exceeds what the background's parallax
// needs (a stem's face within about a metre of the camera), and never so far that what lies 1.5
// times as far lines up: it still moves by twice background_parallax_px at the last step.
TEST(Tangent, NearDepthStepsKeepTheBackgroundMoving) {
  const TangentOptions o;
  const double baseline_px = 0.035 * 724;  // the keyframes' spacing, the working image's focal
  EXPECT_EQ(NearDepthSteps(o, baseline_px, 3.0).first, 0);
  EXPECT_EQ(NearDepthSteps(o, baseline_px, 1.0).first, 0);
  for (const double face_m : {0.3, 0.5, 0.7, 0.9}) {
    SCOPED_TRACE(::testing::Message() << "face " << face_m << " m out");
    const auto [steps, step_m] = NearDepthSteps(o, baseline_px, face_m);
    ASSERT_GT(steps, 0);
    EXPECT_LE(steps, o.near_depth_steps);
    // Each step moves the face by near_depth_step_px.
    EXPECT_NEAR(baseline_px * step_m / (face_m * face_m), o.near_depth_step_px, 1e-9);
    const double background_px = baseline_px / (3 * face_m);
    EXPECT_GE(background_px - steps * o.near_depth_step_px, 2 * o.background_parallax_px);
  }
  TangentOptions off = o;
  off.near_depth_steps = 0;
  EXPECT_EQ(NearDepthSteps(off, baseline_px, 0.5).first, 0);
}

// Seen within a metre, even the nearest keyframe moves a stem's surface by several pixels per
// centimetre of depth: a start a little off misaligned the bark between its outline and the
// stem's, that bark's edges held the circle there, and the next round closed further in. Each
// column is now compared through a few depths about the circle (TangentOptions::
// near_depth_steps). Swept over the bark, the stem's width and distance, and starts 15 % off.
TEST(Tangent, ANearStemsFitDoesNotHangOnItsStart) {
  const PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 67.0);
  for (const Texture texture : {Texture::kLimbShaded, Texture::kRegular}) {
    for (const double radius : {0.08, 0.166}) {
      for (const double distance : {1.7, 2.0}) {
        const Eigen::Vector2d centre(distance, 0.2);
        const RenderedStem scene =
            RenderStems({{centre.x(), centre.y(), radius}}, true, false, texture, camera);
        const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
        for (const double start : {0.85 * radius, 1.15 * radius}) {
          SCOPED_TRACE(::testing::Message()
                       << "texture " << static_cast<int>(texture) << ", r " << radius << " at "
                       << distance << " m, start " << start);
          const TangentFit fit = FitTangentRays(TangentOptions(), views, centre, start, 1.37);
          ASSERT_TRUE(fit.ok);
          // Within 1.1 cm of DBH here; compared through the circle alone, 4 of these 16 fits
          // read 7-21 cm narrow (the 33-cm stem 1.7 m out from either start) and three 1.8-2.4 cm.
          EXPECT_NEAR(fit.radius_m, radius, 0.008);
        }
      }
    }
  }
}

// Views are measured in parallel and gathered in keyframe order: the threads change nothing.
TEST(Tangent, TheFitDoesNotDependOnTheThreads) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const RenderedStem scene = RenderStems({{centre.x(), centre.y(), 0.15}}, true);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  auto fit_with = [&](int threads) {
    const int before = omp_get_max_threads();
    omp_set_num_threads(threads);
    const TangentFit fit = FitTangentRays(TangentOptions().ForImageScale(640.0 / 960.0), views,
                                          centre * (1.0 + 0.3 / centre.norm()), 0.13, 1.37);
    omp_set_num_threads(before);
    return fit;
  };
  const TangentFit one = fit_with(1), three = fit_with(3);
  ASSERT_TRUE(one.ok);
  EXPECT_EQ(one.radius_m, three.radius_m);
  EXPECT_EQ(one.centre, three.centre);
  EXPECT_EQ(one.rays, three.rays);
  EXPECT_EQ(one.two_sided_views, three.two_sided_views);
}

// A sunlit side brighter than a plain sky, the stem's middle darker: the silhouette is the step
// at the lit side's outer border, not the fall from the lit side to the middle.
TEST(Tangent, FitsASunlitStemAgainstAPlainSky) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.15;
  const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}}, false, true);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  const TangentFit fit = FitTangentRays(TangentOptions().ForImageScale(640.0 / 960.0), views,
                                        centre * (1.0 + 0.3 / centre.norm()), 0.13, 1.37);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.radius_m, radius, 0.006);
  EXPECT_LT((fit.centre - centre).norm(), 0.06);
  EXPECT_GT(fit.two_sided_views, 10);
}

// The texture rule's ratio is off (0) or at least 1; the bark's texture is not negative.
TEST(TangentOptions, ChecksTheTextureRule) {
  TangentOptions o;
  EXPECT_NO_THROW(o.Check());
  for (double ratio : {0.0, 1.0, 2.0}) {
    o.plain_background_texture_ratio = ratio;
    EXPECT_NO_THROW(o.Check()) << ratio;
  }
  for (double ratio : {-1.0, 0.5}) {
    o.plain_background_texture_ratio = ratio;
    EXPECT_THROW(o.Check(), InputError) << ratio;
  }
  o.plain_background_texture_ratio = 2.0;
  o.min_bark_texture = -0.1;
  EXPECT_THROW(o.Check(), InputError);
}

// A sunlit side as bright as a plain hazy sky, the stem's middle darker: with the texture rule on
// (TangentOptions::plain_background_texture_ratio), the fall from the lit side to the shaded
// middle is no silhouette (the bark's texture goes on beyond it), whatever the sky's level and
// the stem's size and distance, from a start inside the stem.
TEST(Tangent, FitsASunlitStemAgainstASkyAsBrightAsItsLitSideByItsTexture) {
  TangentOptions o = TangentOptions().ForImageScale(640.0 / 960.0);
  o.plain_background_texture_ratio = 2.0;
  int thin_without_texture = 0;
  for (double sky : {190.0, 200.0, 210.0}) {
    for (const auto& [distance, radius] : {std::pair{4.0, 0.12}, {6.0, 0.15}, {8.0, 0.2}}) {
      const Eigen::Vector2d centre(distance, 0.3);
      const RenderedStem scene =
          RenderStems({{centre.x(), centre.y(), radius}}, false, true, Texture::kIrregular,
                      PinholeCamera::FromHfov(640, 360, 67.0), {}, sky);
      const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
      const TangentFit fit =
          FitTangentRays(o, views, centre * (1.0 + 0.3 / centre.norm()), 0.85 * radius, 1.37);
      SCOPED_TRACE(testing::Message()
                   << "sky " << sky << ", stem r " << radius << " at " << distance << " m");
      ASSERT_TRUE(fit.ok);
      EXPECT_NEAR(fit.radius_m, radius, 0.04 * radius);
      EXPECT_LT((fit.centre - centre).norm(), 0.4 * radius);
      TangentOptions step_alone = o;
      step_alone.plain_background_texture_ratio = 0;
      const TangentFit on_step = FitTangentRays(
          step_alone, views, centre * (1.0 + 0.3 / centre.norm()), 0.85 * radius, 1.37);
      thin_without_texture += !on_step.ok || on_step.radius_m < 0.92 * radius;
    }
  }
  // The brightness step alone closes on the lit side's border (8 % thin or more) in a third
  // of these scenes.
  EXPECT_GE(thin_without_texture, 3);
}

// A nearer stem beside the measured one from most views: told where it stands, the fit leaves
// out the silhouette sides next to it.
TEST(Tangent, LeavesOutSidesBesideANearerStem) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.15;
  const std::vector<Eigen::Vector3d> stems = {{centre.x(), centre.y(), radius}, {3.0, 0.32, 0.12}};
  const RenderedStem scene = RenderStems(stems, true);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray, &stems};
  const TangentFit fit = FitTangentRays(TangentOptions().ForImageScale(640.0 / 960.0), views,
                                        centre * (1.0 + 0.3 / centre.norm()), 0.13, 1.37);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.radius_m, radius, 0.006);
  EXPECT_LT((fit.centre - centre).norm(), 0.08);
  EXPECT_GT(fit.hidden_sides, 0);
  EXPECT_LT(fit.hidden_sides, 2 * fit.tried_views);
  // Each view with a side hidden is not open; at most two sides hidden in each.
  EXPECT_LE(fit.open_views, fit.tried_views - (fit.hidden_sides + 1) / 2);
  EXPECT_GE(fit.open_views, fit.tried_views - fit.hidden_sides);
}

// A stem straight behind a nearer one: from one end of the arc only its left side shows beside
// the nearer stem, from the other only its right. The search stops at the nearer stem's
// silhouette, so the sides that show still measure it.
TEST(Tangent, FitsAStemStraightBehindANearerOne) {
  const Eigen::Vector2d centre(8.0, 0.2);
  const double radius = 0.2;
  const std::vector<Eigen::Vector3d> stems = {{centre.x(), centre.y(), radius}, {4.0, 0.1, 0.15}};
  const RenderedStem scene = RenderStems(stems, true);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray, &stems};
  const TangentFit fit = FitTangentRays(TangentOptions().ForImageScale(640.0 / 960.0), views,
                                        centre * (1.0 + 0.2 / centre.norm()), 0.12, 1.37);
  ASSERT_TRUE(fit.ok);
  // A pixel is 17 mm at the stem here. The depth comes from the arm's 1-m baseline alone (the
  // start, 0.2 m too far, barely holds it): a pixel's error on one side moves it 0.13 m.
  EXPECT_NEAR(fit.radius_m, radius, 0.012);
  const Eigen::Vector2d across = Eigen::Vector2d(-centre.y(), centre.x()).normalized();
  EXPECT_LT(std::abs(across.dot(fit.centre - centre)), 0.03);
  EXPECT_LT((fit.centre - centre).norm(), 0.35);
  EXPECT_GT(fit.hidden_sides, 0);
  EXPECT_LT(2 * fit.two_sided_views, fit.tried_views);
  // Each side shows in views of its own, on one circle to about a pixel.
  EXPECT_TRUE(SidesSeenApart(TangentOptions(), fit, centre.norm() / scene.camera.fx));
}

TEST(Tangent, SideViewsCountEachKeyframeOnce) {
  TangentFit fit;
  for (const auto& [keyframe, side] : {std::pair{3, 0}, {3, 1}, {5, 0}, {3, 0}, {9, 0}}) {
    fit.silhouettes.push_back(
        {keyframe, side, Eigen::Vector2d::UnitY(), Eigen::Vector2d::Zero(), 0.0});
  }
  EXPECT_EQ(fit.SideViews(0), 3);
  EXPECT_EQ(fit.SideViews(1), 1);
  fit.ok = true;
  fit.rms_m = 0.001;
  TangentOptions o;
  o.min_views_each_side = 1;
  EXPECT_TRUE(SidesSeenApart(o, fit, 0.01));
  o.min_views_each_side = 2;
  EXPECT_FALSE(SidesSeenApart(o, fit, 0.01));
}

// Seen from the plot centre, a nearer stem's outline within the stem's own width of its outline.
TEST(Tangent, BesideANearerStem) {
  const std::vector<Eigen::Vector3d> near = {{5.0, 0.0, 0.2}};
  // 0.2 m at 5 m spans ±2.3°; a 0.15-m stem at 9 m ±0.95°, so it is beside it out to
  // 2.3 + 3 × 0.95 = 5.1° (0.80 m across at 9 m).
  EXPECT_TRUE(BesideNearerStem(near, {9.0, 0.0}, 0.15, 0.5));   // straight behind
  EXPECT_TRUE(BesideNearerStem(near, {9.0, 0.70}, 0.15, 0.5));  // a gap of 1.7° beside it
  EXPECT_FALSE(BesideNearerStem(near, {9.0, 0.95}, 0.15, 0.5));
  EXPECT_FALSE(BesideNearerStem(near, {4.0, 0.3}, 0.15, 0.5));   // nearer itself
  EXPECT_FALSE(BesideNearerStem(near, {5.4, 0.45}, 0.15, 0.5));  // as far, within the gap
}

// The cloud saw only one half of the stem (a nearer one hid the rest from the stereo pairs): its
// width is half the stem's and its centre off to one side. The wide start finds both silhouettes.
TEST(Tangent, FitsAStemStartedFromHalfItsWidth) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.15;
  const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}}, true);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  const Eigen::Vector2d across = Eigen::Vector2d(-centre.y(), centre.x()).normalized();
  const Eigen::Vector2d start = centre + 0.06 * across;
  const TangentFit fit = FitTangentRays(TangentOptions().ForImageScale(640.0 / 960.0), views, start,
                                        0.5 * radius, 1.37);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.radius_m, radius, 0.006);
  EXPECT_LT((fit.centre - centre).norm(), 0.06);
  EXPECT_GT(fit.two_sided_views, 10);
}

// A far stem whose stereo points smeared along the line of sight: the part the cloud gives is
// over twice as wide and up to most of a metre too far (beyond max_move_m, within twice the
// centre prior's sigma). Started there, the fit converges onto the stem over its refits; each
// refit finds more silhouettes than the one before.
TEST(Tangent, FitsAFarStemFromASmearedPartTooFarAndTooWide) {
  const Eigen::Vector2d centre(9.1, 1.1);
  const double radius = 0.125;
  const PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 67.0);
  const RenderedStem scene =
      RenderStems({{centre.x(), centre.y(), radius}}, true, false, Texture::kIrregular, camera);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  for (const double too_far_m : {0.55, 0.7}) {
    for (const double too_wide : {1.6, 2.3}) {
      SCOPED_TRACE(::testing::Message() << too_far_m << " m too far, " << too_wide << " wide");
      const Eigen::Vector2d start = centre * (1.0 + too_far_m / centre.norm());
      const TangentFit fit =
          FitTangentRays(TangentOptions(), views, start, too_wide * radius, 1.37);
      ASSERT_TRUE(fit.ok);
      EXPECT_NEAR(fit.radius_m, radius, 0.006);
      EXPECT_LT((fit.centre - centre).norm(), 0.06);
      EXPECT_GT(2 * fit.two_sided_views, fit.tried_views);
    }
  }
}

// A thin stem with a sapling close on either side: the cloud merged the three into one part
// over twice the stem's width, and a search started from that width first takes the gaps
// between them for the stem's inside. The start from half of it finds the stem's own
// silhouettes; so do the refits of the start from the cloud's width alone, each finding more
// silhouettes around the narrower circle than the round before.
TEST(Tangent, FitsAThinStemTheCloudMergedWithSaplingsBesideIt) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.07;
  const std::vector<Eigen::Vector3d> stems = {
      {centre.x(), centre.y(), radius}, {6.1, 0.55, 0.025}, {5.9, 0.04, 0.025}};
  const RenderedStem scene = RenderStems(stems, true);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  const TangentOptions o = TangentOptions().ForImageScale(640.0 / 960.0);
  const TangentFit fit = FitTangentRays(o, views, centre, 0.18, 1.37);
  ASSERT_TRUE(fit.ok);
  EXPECT_NEAR(fit.radius_m, radius, 0.008);
  EXPECT_LT((fit.centre - centre).norm(), 0.08);
  TangentOptions wide_only = o;
  wide_only.narrow_start_scales.clear();
  const TangentFit wide = FitTangentRays(wide_only, views, centre, 0.18, 1.37);
  ASSERT_TRUE(wide.ok);
  EXPECT_NEAR(wide.radius_m, radius, 0.008);
}

// A nearer stem hid most of this one from the stereo pairs: the cloud's part is under half the
// stem's width and its centre lies more than max_sideways_m to one side. The widest start
// supposes that much of a shift and finds both silhouettes.
TEST(Tangent, FitsAStemWhoseCloudPartLiesToOneSide) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.2;
  const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}}, true);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  const Eigen::Vector2d across = Eigen::Vector2d(-centre.y(), centre.x()).normalized();
  const TangentOptions o = TangentOptions().ForImageScale(640.0 / 960.0);
  const Eigen::Vector2d start = centre + 0.13 * across;
  ASSERT_GT(0.13, o.max_sideways_m);
  const TangentFit fit = FitTangentRays(o, views, start, 0.09, 1.37);
  ASSERT_TRUE(fit.ok);
  // Radius within a pixel of these 640-px images (1.2 cm at 6 m) from a start 13 cm off; the
  // depth, from rays over a short arc, within 7 pixels' worth (two refits).
  EXPECT_NEAR(fit.radius_m, radius, 0.012);
  EXPECT_LT((fit.centre - centre).norm(), 0.09);
  EXPECT_GT(fit.two_sided_views, 10);
}

// Stereo smeared a thin stem's points onto the background beside it: the cloud's part has about
// the stem's width but lies a width to one side, so a search from it sees the stem's near side as
// its far one, and finds nothing where it expects the other. A start moved across the line of
// sight finds both silhouettes.
TEST(Tangent, FitsAThinStemTheCloudPlacedAWidthToOneSide) {
  const Eigen::Vector2d centre(7.0, 0.3);
  const double radius = 0.075;
  const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}}, false);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  const Eigen::Vector2d across = Eigen::Vector2d(-centre.y(), centre.x()).normalized();
  const TangentOptions o = TangentOptions().ForImageScale(640.0 / 960.0);
  for (double side : {-1.0, 1.0}) {
    SCOPED_TRACE(side);
    const Eigen::Vector2d start = centre + side * 2 * radius * across;
    const TangentFit fit = FitTangentRays(o, views, start, radius, 1.37);
    ASSERT_TRUE(fit.ok);
    // A pixel is 14 mm at the stem in these 640-px images.
    EXPECT_NEAR(fit.radius_m, radius, 0.007);
    EXPECT_LT(std::abs(across.dot(fit.centre - centre)), 0.02);
    EXPECT_GT(2 * fit.two_sided_views, fit.tried_views);
    TangentOptions in_place = o;
    in_place.sideways_start_shifts.clear();
    const TangentFit unmoved = FitTangentRays(in_place, views, start, radius, 1.37);
    EXPECT_FALSE(unmoved.ok && std::abs(across.dot(unmoved.centre - centre)) < 0.02);
  }
}

// A thin stem straight in front of a thicker one whose outline surrounds its own in most views:
// the cloud merged the thin stem's points with the thick one's bark beside it, a width to one
// side and half again as wide. From there the silhouettes settle on a circle around the thin
// stem's side and the thick one's, both sides in most views; a start moved across the line of
// sight finds the thin stem's own. The bark lines up on the thin stem's circle only, and decides.
// Where the bark lines up nowhere on the chosen fit, a start's fit it lines up on replaces it
// only when narrower: a circle around two things (a thin stem and a thicker one behind it) is
// wider than either, while a wider circle's bark may only follow an elliptical stem's curve
// better where the chosen circle's falls just short. Swept over the wider fit's width.
TEST(FitTheBarkLinesUpOn, OnlyANarrowerFitReplacesTheChosenOne) {
  const TangentOptions o;
  const double px_m = 0.005, radius0 = 0.23;
  auto fit = [](double r, int two_sided) {
    TangentFit f;
    f.ok = true;
    f.centre = {-0.36, -7.40};
    f.radius_m = r;
    f.rms_m = 0.004;
    f.tried_views = 21;
    f.two_sided_views = two_sided;
    return f;
  };
  const TangentFit chosen = fit(0.200, 14);
  const auto lines_up = [](const TangentFit&) { return BarkVerdict::kLinesUp; };
  for (double wider : {0.21, 0.252, 0.3}) {
    // The wider fit shows both sides in more views than the narrower one: still not taken.
    const std::vector<TangentFit> tried = {chosen, fit(wider, 16), fit(0.15, 12)};
    const std::optional<TangentFit> on_bark =
        FitTheBarkLinesUpOn(o, tried, chosen, radius0, px_m, lines_up);
    ASSERT_TRUE(on_bark.has_value()) << wider;
    EXPECT_DOUBLE_EQ(on_bark->radius_m, 0.15) << wider;
    const std::vector<TangentFit> only_wider = {chosen, fit(wider, 16)};
    EXPECT_FALSE(FitTheBarkLinesUpOn(o, only_wider, chosen, radius0, px_m, lines_up)) << wider;
  }
}

// A stem just beside a nearer one on its bearing: a start moved sideways took the nearer stem's
// edge for its own and settled on a looser circle whose bark lines up nowhere. A start's fit at
// most half as loose that stands on its own silhouettes replaces it: first one the bark lines up
// on, else one whose bark too little shows to tell; never one the bark rejects, nor one too loose,
// too narrow or in too few views.
TEST(TighterFitTheBarkAllows, ATighterFitTheBarkDoesNotRejectReplacesTheChosenOne) {
  const TangentOptions o;
  const double px_m = 0.007, radius0 = 0.05;
  auto fit = [&](double r, int two_sided, double rms_px) {
    TangentFit f;
    f.ok = true;
    f.centre = {5.2, 0.2};
    f.radius_m = r;
    f.rms_m = rms_px * px_m;
    f.tried_views = 23;
    f.two_sided_views = two_sided;
    return f;
  };
  const TangentFit chosen = fit(0.044, 18, 1.0);
  const auto verdict_by_radius = [](double lines_up_r, double nothing_r) {
    return [=](const TangentFit& f) {
      if (std::abs(f.radius_m - lines_up_r) < 1e-9) return BarkVerdict::kLinesUp;
      if (std::abs(f.radius_m - nothing_r) < 1e-9) return BarkVerdict::kSaysNothing;
      return BarkVerdict::kLinesUpNowhere;
    };
  };
  // Both sides in 6 views (bark lines up) and in 9 (too little bark shows): the one it lines up
  // on, though in fewer views; without it, the other.
  const std::vector<TangentFit> tried = {chosen, fit(0.052, 6, 0.3), fit(0.049, 9, 0.4)};
  std::optional<TangentFit> taken =
      TighterFitTheBarkAllows(o, tried, chosen, radius0, px_m, verdict_by_radius(0.052, 0.049));
  ASSERT_TRUE(taken.has_value());
  EXPECT_DOUBLE_EQ(taken->radius_m, 0.052);
  taken = TighterFitTheBarkAllows(o, tried, chosen, radius0, px_m, verdict_by_radius(-1, 0.049));
  ASSERT_TRUE(taken.has_value());
  EXPECT_DOUBLE_EQ(taken->radius_m, 0.049);
  EXPECT_FALSE(TighterFitTheBarkAllows(o, tried, chosen, radius0, px_m, verdict_by_radius(-1, -1)));
  // Over half as loose as the chosen fit, too narrow for the cloud's width, or two-sided in two
  // views (and no side in enough views alone): none, whatever the bark says.
  for (const TangentFit& other : {fit(0.052, 6, 0.6), fit(0.015, 6, 0.3), fit(0.052, 2, 0.3)}) {
    const auto any = [](const TangentFit&) { return BarkVerdict::kLinesUp; };
    EXPECT_FALSE(TighterFitTheBarkAllows(o, {chosen, other}, chosen, radius0, px_m, any))
        << other.radius_m << " m, " << other.rms_m / px_m << " px, " << other.two_sided_views;
  }
  TangentOptions off = o;
  off.tighter_rms_share = 0;
  const auto any = [](const TangentFit&) { return BarkVerdict::kLinesUp; };
  EXPECT_FALSE(TighterFitTheBarkAllows(off, tried, chosen, radius0, px_m, any));
}

// Edges that shading makes inside a stem lie on a smaller concentric circle. A start's fit around
// the chosen one replaces it where the rim between them is bark: any such fit, wider by the
// recheck's gain but not many times as wide, offset across the line of sight by no more than the
// radii's difference and a pixel, and tight; the one with the most silhouettes first.
TEST(FitWhoseRimIsBark, AFitAroundTheChosenOneWhoseRimIsBarkReplacesIt) {
  const TangentOptions o;
  const double px_m = 0.006, radius0 = 0.2;
  const Eigen::Vector2d centre(-8.51, 3.86);
  const Eigen::Vector2d across = Eigen::Vector2d(-centre.y(), centre.x()).normalized();
  auto fit = [&](double r, double across_m, int rays, double rms_px = 1.0) {
    TangentFit f;
    f.ok = true;
    f.centre = centre + across_m * across + 0.04 * centre.normalized();
    f.radius_m = r;
    f.rays = rays;
    f.rms_m = rms_px * px_m;
    return f;
  };
  TangentFit chosen = fit(0.152, 0.0, 45);
  chosen.centre = centre;
  const auto rim_is_bark = [](const TangentFit&, double) { return BarkVerdict::kLinesUp; };
  const auto rim_is_not = [](const TangentFit&, double) { return BarkVerdict::kLinesUpNowhere; };
  for (const double side : {-1.0, 1.0}) {
    for (const double across_m : {0.0, 0.02, 0.035, 0.04}) {
      SCOPED_TRACE(::testing::Message() << side * across_m << " m across");
      const std::vector<TangentFit> tried = {chosen, fit(0.189, side * across_m, 31),
                                             fit(0.19, side * across_m, 20)};
      const std::optional<TangentFit> wider =
          FitWhoseRimIsBark(o, tried, chosen, radius0, px_m, rim_is_bark);
      ASSERT_TRUE(wider.has_value());
      EXPECT_EQ(wider->rays, 31);
      EXPECT_FALSE(FitWhoseRimIsBark(o, tried, chosen, radius0, px_m, rim_is_not));
    }
  }
  // Beside it rather than around it, hardly wider, more than 1 / rim_min_share as wide (a
  // sapling within its crown), loose, or beyond the widest start: none.
  for (const TangentFit& other : {fit(0.189, 0.05, 31), fit(0.16, 0.0, 31), fit(0.32, 0.0, 31),
                                  fit(0.189, 0.0, 31, 2.5), fit(0.6, 0.0, 31)}) {
    EXPECT_FALSE(FitWhoseRimIsBark(o, {chosen, other}, chosen, radius0, px_m, rim_is_bark))
        << other.radius_m << " m, " << other.rms_m / px_m << " px";
  }
}

TEST(Tangent, AThinStemInFrontOfAThickerOneKeepsItsOwnOutlineWhereItsBarkLinesUp) {
  const PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 67.0);
  const Eigen::Vector3d thin(7.3, 0.0, 0.063);
  for (const double offset_m : {0.0, 0.05, 0.1, 0.15}) {
    const std::vector<Eigen::Vector3d> stems = {thin, {9.1, offset_m, 0.132}};
    const RenderedStem scene = RenderStems(stems, true, false, Texture::kIrregular, camera);
    const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
    const Eigen::Vector2d centre = thin.head<2>();
    const Eigen::Vector2d across = Eigen::Vector2d(-centre.y(), centre.x()).normalized();
    const Eigen::Vector2d start = centre + 2 * thin.z() * across;
    TangentOptions o;
    const BarkDepthOptions bark;
    const auto lines_up = [&](const TangentFit& f) {
      return JudgeBark(bark, MeasureBarkDepth(bark, o, views, f.centre, f.radius_m, 1.3));
    };
    SCOPED_TRACE(::testing::Message() << "offset " << offset_m << " m");
    const TangentFit fit = FitTangentRays(o, views, start, 1.45 * thin.z(), 1.3, {}, lines_up);
    ASSERT_TRUE(fit.ok);
    // A pixel is 10 mm at the stem here.
    EXPECT_NEAR(fit.radius_m, thin.z(), 0.007);
    // Across the line of sight within half a pixel; along it, where the short arc's parallax
    // holds it (the bark's shift places it later), within 8 cm.
    EXPECT_LT(std::abs(across.dot(fit.centre - centre)), 0.005);
    EXPECT_LT((fit.centre - centre).norm(), 0.08);
    // The silhouettes alone take a circle around the thin stem's side and the thick one's: 0.1-0.25
    // m to the side, 1.2-1.3 times as wide.
    const TangentFit outline = FitTangentRays(o, views, start, 1.45 * thin.z(), 1.3);
    EXPECT_GT((outline.centre - centre).norm(), 0.05);
  }
}

// The cloud merged a thin stem with a thicker one 1-2.3 m behind it, 2-4 degrees beside its
// bearing, and put the part between them at twice the thin stem's width. From that start a circle
// around the thin stem's outline and part of the thicker one's shows both sides in most views
// (before, 9 of these 12 fits: 9.5-22 cm radii for the thin stem's 7.7), so no narrower or sideways
// start was tried; the bark lines up nowhere on it, and one of those starts finds the thin stem.
TEST(Tangent, AThinStemTheCloudMergedWithAThickerOneBehindItGetsItsOwnOutline) {
  const PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 67.0);
  const Eigen::Vector3d thin(8.0, 0.0, 0.077);
  for (const double beside_deg : {2.0, 3.0, 4.0}) {
    for (const double behind_m : {1.0, 2.3}) {
      const double bearing = -beside_deg * M_PI / 180, range = thin.x() + behind_m;
      const Eigen::Vector3d thick(range * std::cos(bearing), range * std::sin(bearing), 0.112);
      const RenderedStem scene =
          RenderStems({thin, thick}, true, false, Texture::kIrregular, camera);
      const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
      const TangentOptions o;
      const BarkDepthOptions bark;
      const auto lines_up = [&](const TangentFit& f) {
        return JudgeBark(bark, MeasureBarkDepth(bark, o, views, f.centre, f.radius_m, 1.3));
      };
      for (const int share_pct : {50, 70}) {
        SCOPED_TRACE(::testing::Message() << beside_deg << " deg beside, " << behind_m
                                          << " m behind, start " << share_pct << " % of the way");
        const double start_bearing = 0.01 * share_pct * bearing;
        const Eigen::Vector2d start(7.95 * std::cos(start_bearing), 7.95 * std::sin(start_bearing));
        const TangentFit fit = FitTangentRays(o, views, start, 2 * thin.z(), 1.3, {}, lines_up);
        ASSERT_TRUE(fit.ok);
        // A pixel is 11 mm at the stem.
        EXPECT_NEAR(fit.radius_m, thin.z(), 0.007);
        EXPECT_LT(std::abs(fit.centre.y() - thin.y()), 0.012);
      }
    }
  }
}

// Rays tangent to the circle (centre, r) from cameras on the arm, one per side and view
// (side 0: the silhouette at the stem's left seen from the camera).
std::vector<TangentFit::Ray> TangentRays(const Eigen::Vector2d& centre, double r, int first,
                                         int last, int side) {
  std::vector<TangentFit::Ray> rays;
  for (int k = first; k <= last; ++k) {
    const double th = std::atan2(centre.y(), centre.x()) + (k - 15) * M_PI / 90;
    const Eigen::Vector2d cam(std::cos(th), std::sin(th));
    const Eigen::Vector2d to = centre - cam;
    const double a = std::asin(r / to.norm()) * (side == 0 ? 1 : -1);
    const Eigen::Vector2d dir = Eigen::Rotation2Dd(a) * to.normalized();
    Eigen::Vector2d n(-dir.y(), dir.x());
    if (n.dot(to) < 0) n = -n;
    rays.push_back({k, side, n, cam, std::atan2(-to.y(), -to.x())});
  }
  return rays;
}

// The start with the most two-sided views caught something beside the stem's left in its last
// views and fitted a wider circle; the narrower start found the stem's own silhouettes in most
// views but was passed over. Pooled, the circle tangent to the most silhouettes is the stem.
TEST(Tangent, PooledSilhouettesGiveTheCircleMostOfThemTouch) {
  const Eigen::Vector2d centre(8.0, 1.0);
  const double r = 0.1;
  TangentFit narrow, wide;
  narrow.ok = wide.ok = true;
  narrow.silhouettes = TangentRays(centre, r, 0, 24, 0);
  for (const auto& ray : TangentRays(centre, r, 10, 20, 1)) narrow.silhouettes.push_back(ray);
  narrow.centre = centre;
  narrow.radius_m = r;
  wide.silhouettes = TangentRays(centre, 1.5 * r, 18, 30, 0);
  for (const auto& ray : TangentRays(centre, 1.5 * r, 16, 30, 1)) wide.silhouettes.push_back(ray);
  wide.centre = centre;
  wide.radius_m = 1.5 * r;
  TangentFit pooled;
  ASSERT_TRUE(FitPooledSilhouettes(TangentOptions(), {&narrow, &wide}, wide, &pooled));
  EXPECT_NEAR(pooled.radius_m, r, 0.001);
  EXPECT_LT((pooled.centre - centre).norm(), 0.01);
  EXPECT_EQ(pooled.rays, 25 + 11);
  EXPECT_EQ(pooled.two_sided_views, 11);  // views 10-20
  EXPECT_EQ(pooled.views, 25);
}

// A thin stem behind a nearer one: one start found both its sides in four views at the end of
// the arc where it shows; another, from the cloud's sliver, caught a pair of bark furrows inside
// a wider circle; a third only loose edges. The first stands on its own rays; narrower than the
// cloud's sliver, or with sides in too few views, it would not.
TEST(Tangent, AStemSeenInFewViewsStandsOnItsTwoSidedViews) {
  const Eigen::Vector2d centre(8.4, 0.4);
  const double r = 0.055;
  TangentFit seen, furrows, loose;
  seen.ok = furrows.ok = loose.ok = true;
  seen.silhouettes = TangentRays(centre, r, 0, 3, 0);
  for (const auto& ray : TangentRays(centre, r, 0, 4, 1)) seen.silhouettes.push_back(ray);
  seen.centre = centre;
  seen.radius_m = r;
  seen.rms_m = 0.002;
  seen.rays = 9;
  seen.two_sided_views = 4;
  furrows = seen;
  furrows.silhouettes = TangentRays(centre, 0.02, 20, 22, 0);
  for (const auto& ray : TangentRays(centre, 0.02, 20, 22, 1)) furrows.silhouettes.push_back(ray);
  furrows.radius_m = 0.02;
  furrows.two_sided_views = 3;
  loose = seen;
  loose.rms_m = 0.02;
  loose.two_sided_views = 6;
  const TangentOptions o;
  const double px_m = 0.0056;  // 8.4 m at 1500 px focal length
  const std::optional<TangentFit> fit =
      FitSeenInFewViews(o, {&furrows, &loose, &seen}, centre, 0.032, px_m);
  ASSERT_TRUE(fit.has_value());
  EXPECT_NEAR(fit->radius_m, r, 0.001);
  EXPECT_LT((fit->centre - centre).norm(), 0.02);
  EXPECT_EQ(fit->two_sided_views, 4);
  EXPECT_EQ(fit->rays, 9);
  // Other evidence (the bark) rejecting that fit: the next best that stands is taken, or none.
  TangentFit fewer = seen;
  fewer.two_sided_views = 3;
  fewer.radius_m = 0.05;
  const std::optional<TangentFit> next =
      FitSeenInFewViews(o, {&furrows, &loose, &seen, &fewer}, centre, 0.032, px_m,
                        [](const TangentFit& f) { return f.two_sided_views != 4; });
  ASSERT_TRUE(next.has_value());
  EXPECT_EQ(next->two_sided_views, 3);
  EXPECT_NEAR(next->radius_m, 0.05, 1e-12);
  EXPECT_FALSE(
      FitSeenInFewViews(o, {&furrows, &loose, &seen}, centre, 0.032, px_m, [](const TangentFit&) {
        return false;
      }).has_value());
  // The sliver the cloud saw is wider than the fit: not a hidden stem.
  EXPECT_FALSE(FitSeenInFewViews(o, {&furrows, &loose, &seen}, centre, 0.07, px_m).has_value());
  TangentOptions stricter = o;
  stricter.few_views_min_two_sided = 5;
  EXPECT_FALSE(FitSeenInFewViews(stricter, {&furrows, &seen}, centre, 0.032, px_m).has_value());
}

// A 37.7-cm stem 9 m out, half behind a nearer one: the few-views fit from a start on the
// cloud's sliver was still widening when its rounds ended (30.2 cm); searched again from its
// circle it settles (37.6 cm) on as many silhouettes, both sides in one view fewer. A refit that
// loses silhouettes, loosens, or runs past the widest start does not replace it.
TEST(Tangent, ASettledFewViewsFitReplacesOneStillWidening) {
  const TangentOptions o;
  const Eigen::Vector2d centre0(7.87, -4.32);
  const TangentFit few = FitOf({7.745, -4.429}, 0.151, 0.0053, 27, 3);
  const TangentFit settled = FitOf({7.848, -4.535}, 0.188, 0.0043, 26, 2);
  EXPECT_TRUE(SettledFitReplaces(o, few, settled, centre0, 0.100));
  const std::vector<std::pair<const char*, std::function<void(TangentFit&)>>> worse = {
      {"fewer silhouettes", [](TangentFit& f) { f.rays = 22; }},
      {"both sides in one view", [](TangentFit& f) { f.two_sided_views = 1; }},
      {"looser", [](TangentFit& f) { f.rms_m = 0.0060; }},
      {"beyond 2.75 times the cloud's radius", [](TangentFit& f) { f.radius_m = 0.3; }},
      {"no fit", [](TangentFit& f) { f.ok = false; }}};
  for (const auto& [what, change] : worse) {
    SCOPED_TRACE(what);
    TangentFit refit = settled;
    change(refit);
    EXPECT_FALSE(SettledFitReplaces(o, few, refit, centre0, 0.100));
  }
}

// A near stem whose fit is right from the start: the wider start settles on the same circle, and
// the check leaves the fit as it was (it replaces only a fit that a wider start beats cleanly).
TEST(Tangent, AWiderStartLeavesARightFitAlone) {
  const Eigen::Vector2d centre(2.7, 0.1);
  const double radius = 0.074;
  const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}}, true, true);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  TangentOptions o = TangentOptions().ForImageScale(640.0 / 960.0);
  ASSERT_GT(o.recheck_wider_scale, 1.0);
  const TangentFit fit = FitTangentRays(o, views, centre, 0.093, 1.37);
  o.recheck_wider_scale = 0;
  const TangentFit unchecked = FitTangentRays(o, views, centre, 0.093, 1.37);
  ASSERT_TRUE(fit.ok);
  EXPECT_GT(2 * fit.two_sided_views, fit.tried_views);
  EXPECT_NEAR(fit.radius_m, radius, 0.003);
  EXPECT_EQ(fit.radius_m, unchecked.radius_m);
  EXPECT_EQ(fit.centre, unchecked.centre);
}

// A fit that closed inside the stem (both sides in two thirds of the views) against the wider
// start's whole stem (both sides in all): the wider one wins within the rms slack, swept over
// the extra rms, and loses beyond it or when it is two-sided in no more views.
TEST(Tangent, AWiderRecheckTwoSidedInAsManyViewsWinsWithinTheRmsSlack) {
  const TangentOptions o;
  const Eigen::Vector2d centre0(5.9, -4.3);
  const double radius0 = 0.15, px_m = centre0.norm() / 1600.0;
  TangentFit fit, wider;
  fit.ok = wider.ok = true;
  fit.centre = wider.centre = centre0;
  fit.radius_m = 0.108;
  wider.radius_m = 0.189;
  fit.tried_views = wider.tried_views = 26;
  fit.two_sided_views = 16;
  wider.two_sided_views = 26;
  fit.rms_m = 1.1 * px_m;
  for (double extra_px : {-0.2, 0.0, 0.1, 0.2, 0.3, 0.6}) {
    wider.rms_m = fit.rms_m + extra_px * px_m;
    EXPECT_EQ(WiderRecheckWins(o, fit, wider, centre0, radius0, px_m),
              extra_px <= o.recheck_rms_slack_px)
        << "extra rms " << extra_px << " px";
  }
  // As many two-sided views (both fits whole in every view): a fit closed inside the stem is
  // no tighter than the stem's outline by more than noise.
  wider.two_sided_views = fit.two_sided_views;
  wider.rms_m = fit.rms_m + 0.1 * px_m;
  EXPECT_TRUE(WiderRecheckWins(o, fit, wider, centre0, radius0, px_m));
  wider.rms_m = fit.rms_m + 0.3 * px_m;
  EXPECT_FALSE(WiderRecheckWins(o, fit, wider, centre0, radius0, px_m));
  wider.two_sided_views = fit.two_sided_views - 1;
  wider.rms_m = fit.rms_m + 0.1 * px_m;
  EXPECT_FALSE(WiderRecheckWins(o, fit, wider, centre0, radius0, px_m)) << "fewer two-sided";
  wider.centre = centre0 + 0.2 * Eigen::Vector2d(centre0.y(), -centre0.x()).normalized();
  wider.two_sided_views = 26;
  EXPECT_FALSE(WiderRecheckWins(o, fit, wider, centre0, radius0, px_m)) << "beside the fit";
}

TEST(Tangent, DegenerateSystems) {
  Eigen::Vector2d c;
  double r, sd, rms;
  EXPECT_FALSE(
      SolveTangentCircle({{1, 0}, {0, 1}}, {{0, 0}, {0, 0}}, 0.004, &c, &r, &sd, &rms, nullptr));
}

// The fit of a thin stem's smeared cloud, 2.4 times its width, whose rounds came in part of the
// way (0.142 -> 0.092 m) and stopped; refined again from its own circle it reaches the stem
// (0.058 m) on more silhouettes, both sides in every view, tighter, and replaces it. Swept over
// what makes a refit no better: fewer silhouettes, fewer two-sided views, a looser circle, or
// narrower than a fit that can stand for the stem (a sapling's own stem within its crown).
TEST(Tangent, ASettledChosenFitReplacesOneStillNarrowing) {
  const TangentOptions o;
  const double radius0 = 0.142;
  TangentFit chosen = FitOf({0.763, -6.175}, 0.092, 0.0074, 36, 15);
  chosen.last_change_m = 0.013;
  TangentFit settled = FitOf({0.734, -6.219}, 0.058, 0.0035, 42, 21);
  settled.last_change_m = 0.013;
  EXPECT_TRUE(SettledChosenFitReplaces(o, chosen, settled, radius0));
  const std::vector<std::pair<const char*, std::function<void(TangentFit&)>>> worse = {
      {"fewer silhouettes", [](TangentFit& f) { f.rays = 35; }},
      {"both sides in fewer views", [](TangentFit& f) { f.two_sided_views = 14; }},
      {"looser", [](TangentFit& f) { f.rms_m = 0.0075; }},
      {"under 0.35 of the cloud's radius", [](TangentFit& f) { f.radius_m = 0.049; }},
      {"no fit", [](TangentFit& f) { f.ok = false; }}};
  for (const auto& [what, change] : worse) {
    SCOPED_TRACE(what);
    TangentFit refit = settled;
    change(refit);
    EXPECT_FALSE(SettledChosenFitReplaces(o, chosen, refit, radius0));
  }
}

// A chosen fit is refined again only where its last round still changed the radius, and kept
// only where that tightens it: on stems whose starts converge within the refits (too narrow,
// right, or over twice too wide; plain sky or a textured background), the fits are those without
// it.
TEST(Tangent, SettlingLeavesASettledFitAlone) {
  const PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 67.0);
  const Eigen::Vector2d centre(6.2, 0.8);
  for (const double radius : {0.058, 0.12}) {
    for (const bool textured : {true, false}) {
      const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}}, textured, false,
                                             Texture::kIrregular, camera);
      const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
      for (const double start_scale : {0.6, 1.0, 1.8, 2.4}) {
        SCOPED_TRACE(::testing::Message() << "radius " << radius << ", textured " << textured
                                          << ", start " << start_scale << " times");
        TangentOptions without;
        without.settle_min_change_share = 0;
        const TangentFit settled =
            FitTangentRays(TangentOptions(), views, centre, start_scale * radius, 1.37);
        const TangentFit plain = FitTangentRays(without, views, centre, start_scale * radius, 1.37);
        ASSERT_TRUE(settled.ok);
        ASSERT_TRUE(plain.ok);
        EXPECT_NEAR(settled.radius_m, radius, 0.004);
        EXPECT_NEAR(settled.radius_m, plain.radius_m, 0.001);
        EXPECT_LT((settled.centre - plain.centre).norm(), 0.002);
      }
    }
  }
}

}  // namespace
}  // namespace stemmap::stems
