#include "stemmap/stems/bark_depth.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <utility>

#include "stemmap/core/check_message.h"
#include "stemmap/core/error.h"
#include "stemmap/stems/test_scene.h"

namespace stemmap::stems {
namespace {

// A circle with the stem's apparent width, `shift_m` farther along the line from the plot centre
// (as the tangent rays leave it when their parallax errs).
struct Start {
  Eigen::Vector2d centre;
  double radius;
};
Start MovedAlongTheLineOfSight(const Eigen::Vector2d& centre, double radius, double shift_m) {
  const double cam_dist = centre.norm() - 0.95;  // the cameras stand on the arm, facing out
  return {centre + shift_m * centre.normalized(), radius * (cam_dist + shift_m) / cam_dist};
}

// The bark finds the distance that the silhouettes missed, on either side, to about a centimetre
// (a pixel is 1.2 cm at the stem here).
TEST(BarkDepth, FindsTheDistanceOfABarkedStem) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.15;
  const RenderedStem scene =
      RenderStems({{centre.x(), centre.y(), radius}}, true, false, Texture::kIrregular);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  for (double error_m : {-0.12, 0.0, 0.08, 0.2}) {
    SCOPED_TRACE(error_m);
    const Start s = MovedAlongTheLineOfSight(centre, radius, error_m);
    const BarkDepth d =
        MeasureBarkDepth(BarkDepthOptions(), TangentOptions(), views, s.centre, s.radius, 1.37);
    ASSERT_TRUE(d.ok);
    EXPECT_NEAR(d.shift_m, -error_m, 0.012);
    EXPECT_GT(d.peak_ncc, 0.8);
    EXPECT_GE(d.pairs, BarkDepthOptions().min_pairs);
    // The radius follows the distance: the circle keeps the stem's apparent width.
    EXPECT_NEAR(s.radius * d.scale, radius, 0.002);
  }
}

// Bark without texture says nothing about the distance, and a distance off by more than the
// search reaches finds no peak inside it: neither moves the stem.
TEST(BarkDepth, NoTextureOrNoPeakLeavesTheStem) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.15;
  const RenderedStem plain =
      RenderStems({{centre.x(), centre.y(), radius}}, true, false, Texture::kPlainBark);
  const TangentViews plain_views{&plain.camera, &plain.keyframes, &plain.gray};
  EXPECT_FALSE(
      MeasureBarkDepth(BarkDepthOptions(), TangentOptions(), plain_views, centre, radius, 1.37).ok);
  const RenderedStem barked =
      RenderStems({{centre.x(), centre.y(), radius}}, true, false, Texture::kIrregular);
  const TangentViews views{&barked.camera, &barked.keyframes, &barked.gray};
  const Start far = MovedAlongTheLineOfSight(centre, radius, 0.6);
  BarkDepthOptions o;
  o.search_m = 0.25;
  const BarkDepth beyond =
      MeasureBarkDepth(o, TangentOptions(), views, far.centre, far.radius, 1.37);
  EXPECT_FALSE(beyond.ok);
  EXPECT_TRUE(beyond.at_search_end);  // the bark lines up best toward the stem
  o.enabled = false;
  EXPECT_FALSE(MeasureBarkDepth(o, TangentOptions(), views, centre, radius, 1.37).ok);
}

// A nearer stem across the bark in every view leaves no pair to compare.
TEST(BarkDepth, BarkBehindANearerStemIsNotCompared) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const std::vector<Eigen::Vector3d> occluders = {{3.0, 0.15, 0.2}};
  const RenderedStem scene =
      RenderStems({{centre.x(), centre.y(), 0.15}, occluders[0]}, true, false, Texture::kIrregular);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray, &occluders};
  const BarkDepth d =
      MeasureBarkDepth(BarkDepthOptions(), TangentOptions(), views, centre, 0.15, 1.37);
  EXPECT_FALSE(d.ok);
  EXPECT_LT(d.pairs, BarkDepthOptions().min_pairs);
}

// A nearer stem beside the line of sight hides part of the bark in many views: the part it
// leaves free is compared, and the distance is found as well.
TEST(BarkDepth, PartlyHiddenBarkStillPlacesTheStem) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.15;
  const std::vector<Eigen::Vector3d> occluders = {{3.0, 0.28, 0.06}};
  const RenderedStem scene = RenderStems({{centre.x(), centre.y(), radius}, occluders[0]}, true,
                                         false, Texture::kIrregular);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray, &occluders};
  const Start s = MovedAlongTheLineOfSight(centre, radius, 0.1);
  const BarkDepth d =
      MeasureBarkDepth(BarkDepthOptions(), TangentOptions(), views, s.centre, s.radius, 1.37);
  ASSERT_TRUE(d.ok);
  EXPECT_NEAR(d.shift_m, -0.1, 0.015);
}

// Leaves in front of the stem (a sapling's crown, swaying) cover its bark from part of the arc:
// those views' pairs line up nowhere, and with them in the mean the bark looks like no stem's.
// Left out, the rest place the stem; when they are more than a third of the views, nothing is
// left out and the bark says nothing.
TEST(BarkDepth, ViewsWhereLeavesCoverTheBarkAreLeftOut) {
  const Eigen::Vector2d centre(6.0, 0.3);
  const double radius = 0.15;
  RenderedStem scene =
      RenderStems({{centre.x(), centre.y(), radius}}, true, false, Texture::kIrregular);
  cv::RNG rng(5);
  const auto cover = [&](int k) {  // leaves, different in every view, over the stem's middle
    const Rigid3d cam_from_world = scene.keyframes[k].world_from_cam.Inverse();
    const Eigen::Vector3d p = cam_from_world * Eigen::Vector3d(centre.x(), centre.y(), 1.37);
    if (p.z() <= 0) return;
    const Eigen::Vector2d px = scene.camera.ImageFromCam(p);
    const double half_px = 1.5 * scene.camera.fx * radius / p.z();
    const cv::Rect box = cv::Rect(cv::Point(px.x() - half_px, px.y() - 40),
                                  cv::Point(px.x() + half_px, px.y() + 40)) &
                         cv::Rect(0, 0, scene.camera.width, scene.camera.height);
    if (box.area() > 0) rng.fill(scene.gray[k](box), cv::RNG::UNIFORM, 40, 200);
  };
  for (int k = 26; k < 34; ++k) cover(k);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  const Start s = MovedAlongTheLineOfSight(centre, radius, 0.1);
  const BarkDepth d =
      MeasureBarkDepth(BarkDepthOptions(), TangentOptions(), views, s.centre, s.radius, 1.37);
  ASSERT_TRUE(d.ok);
  EXPECT_NEAR(d.shift_m, -0.1, 0.015);
  EXPECT_GT(d.peak_ncc, 0.8);
  BarkDepthOptions all_views;
  all_views.max_hidden_view_share = 0;
  const BarkDepth mean_of_all =
      MeasureBarkDepth(all_views, TangentOptions(), views, s.centre, s.radius, 1.37);
  EXPECT_FALSE(mean_of_all.ok);
  // Leaves over half the views: the circle's inside is taken for no stem's bark.
  for (int k = 10; k < 26; ++k) cover(k);
  const BarkDepth mostly_hidden =
      MeasureBarkDepth(BarkDepthOptions(), TangentOptions(), views, s.centre, s.radius, 1.37);
  EXPECT_FALSE(mostly_hidden.ok);
}

// The bark lines up, lines up nowhere (a circle around two things), or cannot tell: too few views
// show it, or it correlates alike at every distance (no peak: it cannot place the circle, which
// says nothing against it).
// The rim of a stem's circle beyond a narrower circle inside it is bark, and lines up through the
// stem's circle; the rim of a wider circle around the stem is what lies behind it, and does not.
// Swept over the narrower circle's share of the stem, the wider one's of it, and limbs shaded or
// not (shading that falls off toward the limbs is what makes edges inside a stem); and with a
// stem behind on one side.
TEST(BarkDepth, TheRimBeyondACircleInsideTheStemIsItsBark) {
  const PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 67.0);
  const Eigen::Vector2d centre(7.0, 0.3);
  const double radius = 0.18;
  const BarkDepthOptions o;
  for (const Texture texture : {Texture::kIrregular, Texture::kLimbShaded}) {
    const RenderedStem scene =
        RenderStems({{centre.x(), centre.y(), radius}}, true, false, texture, camera);
    const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
    for (const double inner : {0.6, 0.7, 0.8}) {
      SCOPED_TRACE(::testing::Message() << "inner circle " << inner << " of the stem");
      const BarkDepth rim =
          MeasureRimBark(o, TangentOptions(), views, centre, radius, inner * radius, 1.37);
      EXPECT_EQ(JudgeBark(o, rim), BarkVerdict::kLinesUp) << rim.peak_ncc;
      EXPECT_NEAR(rim.shift_m, 0.0, 0.01);
    }
    for (const double outer : {1.25, 1.4}) {
      SCOPED_TRACE(::testing::Message() << "outer circle " << outer << " of the stem");
      const BarkDepth rim =
          MeasureRimBark(o, TangentOptions(), views, centre, outer * radius, radius, 1.37);
      EXPECT_NE(JudgeBark(o, rim), BarkVerdict::kLinesUp) << rim.peak_ncc;
    }
  }
  // A darker stem 1.6 m behind fills the wider circle's rim on one side, a plain sky the other:
  // the sides differ in brightness whatever the warp, so each side is correlated on its own.
  const RenderedStem behind = RenderStems({{centre.x(), centre.y(), radius}, {8.6, 0.8, 0.2}},
                                          false, false, Texture::kIrregular, camera);
  const TangentViews behind_views{&behind.camera, &behind.keyframes, &behind.gray};
  const BarkDepth rim =
      MeasureRimBark(o, TangentOptions(), behind_views, centre, 1.25 * radius, radius, 1.37);
  EXPECT_NE(JudgeBark(o, rim), BarkVerdict::kLinesUp) << rim.peak_ncc;
  // A rim a few pixels wide says nothing, and there is none where the narrower circle reaches its
  // outer edge.
  const RenderedStem scene =
      RenderStems({{centre.x(), centre.y(), radius}}, true, false, Texture::kIrregular, camera);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  for (const double inner : {0.9, 1.0}) {
    const BarkDepth rim =
        MeasureRimBark(o, TangentOptions(), views, centre, radius, inner * radius, 1.37);
    EXPECT_EQ(JudgeBark(o, rim), BarkVerdict::kSaysNothing) << inner;
  }
}

TEST(JudgeBark, TellsBarkThatLinesUpNowhereFromBarkThatCannotTell) {
  const BarkDepthOptions o;
  BarkDepth b;
  b.pairs = o.min_pairs;
  b.ok = true;
  EXPECT_EQ(JudgeBark(o, b), BarkVerdict::kLinesUp);
  b.ok = false;
  b.peak_ncc = 0.5;
  EXPECT_EQ(JudgeBark(o, b), BarkVerdict::kLinesUpNowhere);
  b.peak_ncc = 0.9;
  b.end_ncc = 0.89;  // no peak
  EXPECT_EQ(JudgeBark(o, b), BarkVerdict::kSaysNothing);
  b.at_search_end = true;
  EXPECT_EQ(JudgeBark(o, b), BarkVerdict::kLinesUpNowhere);
  b.at_search_end = false;
  b.peak_ncc = 0.5;
  b.pairs = o.min_pairs - 1;
  EXPECT_EQ(JudgeBark(o, b), BarkVerdict::kSaysNothing);
}

TEST(BarkDepth, OptionsAreChecked) {
  EXPECT_NO_THROW(BarkDepthOptions().Check());
  BarkDepthOptions o;
  o.step_m = 0;
  EXPECT_THROW(o.Check(), InputError);
  o = BarkDepthOptions();
  o.baseline_m = 3.0;
  EXPECT_THROW(o.Check(), InputError);
  o = BarkDepthOptions();
  o.min_pixels = o.max_pixels + 1;
  EXPECT_THROW(o.Check(), InputError);
  o = BarkDepthOptions();
  o.max_hidden_view_share = 1.0;
  EXPECT_EQ(CheckMessage(o), "the share of views leaves may hide from the bark must lie in [0, 1)");
  for (const auto& [gap, outer] : {std::pair{-0.01, 0.95}, {0.3, 0.2}, {0.03, 1.1}}) {
    o = BarkDepthOptions();
    o.rim_gap_share = gap;
    o.rim_outer_share = outer;
    EXPECT_EQ(CheckMessage(o),
              "the bark's rim must reach from a share of the width at least 0 up to one greater, "
              "at most 1")
        << gap << ", " << outer;
  }
}

}  // namespace
}  // namespace stemmap::stems
