#include "stemmap/stems/refine.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "stemmap/core/check_message.h"
#include "stemmap/stems/silhouette.h"
#include "stemmap/stems/test_scene.h"

namespace stemmap::stems {
namespace {

// A 30 cm stem 5 m away as the cloud saw it, and a silhouette fit that agrees to a few mm in
// five views with both sides.
struct Case {
  Stem stem;
  TangentFit fit;
  double px_m = 5.0 / 1400.0;
  Case() {
    stem.centre_xy = {5.0, 0.0};
    stem.dbh_slice_m = 0.30;
    fit.ok = true;
    fit.centre = stem.centre_xy;
    fit.radius_m = 0.152;
    fit.rms_m = 0.002;
    fit.views = fit.tried_views = fit.two_sided_views = 5;
  }
};

Stem Fitted(double x, double y, double dbh_m, double shift_m) {
  Stem s;
  s.centre_xy = {x, y};
  s.dbh_m = dbh_m;
  s.fit_shift_m = shift_m;
  return s;
}

// A stem seen 12 cm wide, its right side hidden, up to 60 cm wide: the stand's stems of 20, 30
// and 40 cm lie between (the 8- and 70-cm ones do not), so it reads their mean, 30 cm, and its
// centre moves away from the plot centre and to the right by the radius gained, its face and
// seen side held. With too few of the stand between, the middle of the two.
TEST(WidthsFromStand, AStemSeenInPartTakesTheStandsMeanBetweenItsBounds) {
  MeasureOptions o;
  std::vector<Stem> stems;
  for (const double d : {0.08, 0.20, 0.30, 0.40, 0.70}) stems.push_back(Fitted(0, 4, d, 0));
  Stem part = Fitted(8.0, 0.0, 0.12, 0);
  part.dbh_seen_m = 0.12;
  part.dbh_hidden_max_m = 0.60;
  part.hidden_side = 1;
  stems.push_back(part);
  WidthsFromStand(o, &stems);
  const Stem& s = stems.back();
  EXPECT_NEAR(s.dbh_m, 0.30, 1e-9);
  EXPECT_TRUE(s.flags.Has(StemFlag::kWidthFromStand));
  EXPECT_NEAR(s.centre_xy.x(), 8.09, 1e-9);   // away from the plot centre by 9 cm
  EXPECT_NEAR(s.centre_xy.y(), -0.09, 1e-9);  // and to the right (image right: -y looking +x)
  for (size_t i = 0; i + 1 < stems.size(); ++i) {
    EXPECT_FALSE(stems[i].flags.Has(StemFlag::kWidthFromStand));
  }
  o.hidden_side_stand_min_stems = 4;
  stems.back() = part;
  WidthsFromStand(o, &stems);
  EXPECT_NEAR(stems.back().dbh_m, 0.36, 1e-9);
}

TEST(PlaceFittedOccluders, FittedStemsReplaceTheirPartsCircle) {
  std::vector<Eigen::Vector3d> occluders = {{1, 0, 0.1}, {5, 0, 0.3}, {9, 0, 0.2}};
  std::vector<Stem> fitted(2);
  fitted[0].centre_xy = {5.1, 0.2};
  fitted[0].dbh_m = 0.5;          // the cloud's
  fitted[0].dbh_tangent_m = 0.4;  // the silhouettes'
  fitted[1].centre_xy = {5.4, -0.3};
  fitted[1].dbh_m = 0.2;
  PlaceFittedOccluders(fitted, {}, 1, true, &occluders);
  ASSERT_EQ(occluders.size(), 4u);
  EXPECT_EQ(occluders[0], Eigen::Vector3d(1, 0, 0.1));
  EXPECT_EQ(occluders[1], Eigen::Vector3d(5.1, 0.2, 0.2));
  EXPECT_EQ(occluders[2], Eigen::Vector3d(9, 0, 0.2));
  EXPECT_EQ(occluders[3], Eigen::Vector3d(5.4, -0.3, 0.1));
  // A part that became nothing keeps its cloud circle only where asked to.
  PlaceFittedOccluders({}, {}, 2, true, &occluders);
  EXPECT_EQ(occluders[2], Eigen::Vector3d(9, 0, 0.2));
  PlaceFittedOccluders({}, {}, 0, false, &occluders);
  EXPECT_EQ(occluders[0], kNoOccluder);
  EXPECT_FALSE(BesideNearerStem({kNoOccluder}, {5.0, 0.0}, 0.2, 0.0));
  // One that became a stem stands as it.
  occluders[0] = {1, 0, 0.1};
  PlaceFittedOccluders(std::span(fitted).first(1), {}, 0, false, &occluders);
  EXPECT_EQ(occluders[0], Eigen::Vector3d(5.1, 0.2, 0.2));
}

TEST(PlaceFittedOccluders, LeavesHideWhatTheirOutlinesCover) {
  std::vector<Eigen::Vector3d> occluders = {{1, 0, 0.1}, {5, 0, 0.3}};
  const std::vector<Eigen::Vector3d> leaves = {{5.2, 0.1, 0.05}, {5.3, -0.2, 0.04}};
  // A part that became nothing but leaves: they stand in its place, as its silhouettes saw them.
  PlaceFittedOccluders({}, leaves, 1, true, &occluders);
  ASSERT_EQ(occluders.size(), 3u);
  EXPECT_EQ(occluders[1], leaves[0]);
  EXPECT_EQ(occluders[2], leaves[1]);
  // Also where the part itself would hide nothing.
  PlaceFittedOccluders({}, std::span(leaves).first(1), 0, false, &occluders);
  EXPECT_EQ(occluders[0], leaves[0]);
  // Beside a stem the part became, they hide what lies behind them too.
  std::vector<Stem> fitted(1);
  fitted[0].centre_xy = {5.0, 0.0};
  fitted[0].dbh_m = 0.3;
  PlaceFittedOccluders(fitted, std::span(leaves).last(1), 1, true, &occluders);
  ASSERT_EQ(occluders.size(), 4u);
  EXPECT_EQ(occluders[1], Eigen::Vector3d(5.0, 0.0, 0.15));
  EXPECT_EQ(occluders[3], leaves[1]);
}

// Stereo smear: a 14.4-cm stem at 5.7 m, and a part 0.7 m behind it on nearly its bearing.
TEST(InShadowOfNearerStem, APointStraightBehindAListedStem) {
  const std::vector<Stem> nearer = {Fitted(-2.70, 5.04, 0.144, 0.0)};
  EXPECT_TRUE(InShadowOfNearerStem(nearer, {-2.96, 5.66}));
  // Beside its width seen from the centre, in front of it, or within it: no shadow.
  EXPECT_FALSE(InShadowOfNearerStem(nearer, {-2.52, 5.83}));
  EXPECT_FALSE(InShadowOfNearerStem(nearer, {-1.35, 2.52}));
  EXPECT_FALSE(InShadowOfNearerStem(nearer, {-2.72, 5.08}));
  EXPECT_FALSE(InShadowOfNearerStem({}, {-2.96, 5.66}));
}

// A fit whose silhouettes are the given (keyframe, side) rays, over `views` keyframes, none
// two-sided, scattering rms_m about its circle.
TangentFit FitOnSilhouettes(const std::vector<std::array<int, 2>>& rays, int views, double rms_m) {
  TangentFit f;
  f.ok = true;
  f.rms_m = rms_m;
  for (const auto& [keyframe, side] : rays) {
    f.silhouettes.push_back(
        {keyframe, side, Eigen::Vector2d::UnitY(), Eigen::Vector2d::Zero(), 0.0, 0.0});
  }
  f.rays = static_cast<int>(f.silhouettes.size());
  f.views = views;
  f.two_sided_views = 0;
  return f;
}

// What may stand straight behind a nearer stem: both sides in three views on one circle, or
// many silhouettes (26, both sides in two views, as a large stem seen past a nearer one gives)
// to within a pixel.
TEST(StandsOnItsOwnSilhouettes, TwoSidedViewsOrManyTightSilhouettes) {
  const TangentOptions o;
  const double px_m = 0.006;
  TangentFit f;
  f.ok = true;
  f.rays = 26;
  f.two_sided_views = 2;
  f.rms_m = 0.0043;
  EXPECT_TRUE(StandsOnItsOwnSilhouettes(o, f, px_m));
  f.rms_m = 0.009;  // 1.5 px
  EXPECT_FALSE(StandsOnItsOwnSilhouettes(o, f, px_m));
  f.two_sided_views = 3;
  EXPECT_TRUE(StandsOnItsOwnSilhouettes(o, f, px_m));
  f.two_sided_views = 1;
  f.rms_m = 0.0042;
  f.rays = 9;  // few silhouettes: a stem hidden behind a wide one near the tripod
  EXPECT_FALSE(StandsOnItsOwnSilhouettes(o, f, px_m));
  f.rays = 26;
  f.ok = false;
  EXPECT_FALSE(StandsOnItsOwnSilhouettes(o, f, px_m));
}

// A stem straight behind a nearer one, seen past it from either end of the arm: its left side
// in some views, its right side in others, never both at once, on one circle to under a pixel.
TEST(StandsOnItsOwnSilhouettes, EachSideInViewsOfItsOwn) {
  const TangentOptions o;
  const double px_m = 0.006;
  std::vector<std::array<int, 2>> rays;
  for (int k = 0; k < 10; ++k) rays.push_back({10 * (k < 5 ? 0 : 1) + k, k < 5 ? 0 : 1});
  TangentFit f = FitOnSilhouettes(rays, 10, 0.0045);  // 0.75 px
  EXPECT_TRUE(StandsOnItsOwnSilhouettes(o, f, px_m));
  f.rms_m = 0.009;  // 1.5 px: edges of what stands around it
  EXPECT_FALSE(StandsOnItsOwnSilhouettes(o, f, px_m));
  f.rms_m = 0.0045;
  // Ten rays of one side (the nearer stem's own edge, seen past it from one end of the arm).
  for (TangentFit::Ray& r : f.silhouettes) r.side = 0;
  EXPECT_FALSE(StandsOnItsOwnSilhouettes(o, f, px_m));
  // The right side in three views only.
  for (size_t i = 7; i < f.silhouettes.size(); ++i) f.silhouettes[i].side = 1;
  EXPECT_FALSE(StandsOnItsOwnSilhouettes(o, f, px_m));
  f.silhouettes[6].side = 1;
  EXPECT_TRUE(StandsOnItsOwnSilhouettes(o, f, px_m));
  TangentOptions off = o;
  off.min_views_each_side = 0;
  EXPECT_FALSE(StandsOnItsOwnSilhouettes(off, f, px_m));
}

// Sides seen one at a time past a nearer stem count where each shows clear of its outline: a
// smear 0.6 m behind a 10-cm stem 8 m out had both sides in 15 views, on one circle to 0.9 px,
// but clear of the stem's outline in 5 and 2 of them (its own edges).
TEST(SidesSeenApartPastNearer, EachSideClearOfTheNearerStemsOutline) {
  const TangentOptions o;
  const double px_m = 0.006;
  std::vector<std::array<int, 2>> rays;
  for (int k = 0; k < 30; ++k) rays.push_back({k / 2, k % 2});
  TangentFit f = FitOnSilhouettes(rays, 15, 0.0054);  // 0.9 px
  EXPECT_TRUE(SidesSeenApartPastNearer(o, f, {15, 15}, px_m));
  EXPECT_TRUE(SidesSeenApartPastNearer(o, f, {4, 4}, px_m));
  EXPECT_FALSE(SidesSeenApartPastNearer(o, f, {5, 2}, px_m));
  EXPECT_FALSE(SidesSeenApartPastNearer(o, f, {0, 15}, px_m));
  f.rms_m = 0.009;  // 1.5 px: not one circle
  EXPECT_FALSE(SidesSeenApartPastNearer(o, f, {15, 15}, px_m));
}

TEST(HasSharpSilhouettes, BothSidesInThreeViewsOnOneCircleToHalfAPixel) {
  // A thin stem far out behind a wider one: 10 rays, 4 views two-sided, 1.6 mm.
  const double px_m = 0.0058;
  TangentFit f;
  f.ok = true;
  f.rays = 10;
  f.two_sided_views = 4;
  f.rms_m = 0.0016;
  EXPECT_TRUE(HasSharpSilhouettes(f, 0.5, px_m));
  f.rms_m = 0.0048;  // a fit from a start 0.3 m off: 0.8 px
  EXPECT_FALSE(HasSharpSilhouettes(f, 0.5, px_m));
  f.rms_m = 0.0016;
  f.two_sided_views = 2;
  EXPECT_FALSE(HasSharpSilhouettes(f, 0.5, px_m));
  f.two_sided_views = 3;
  f.ok = false;
  EXPECT_FALSE(HasSharpSilhouettes(f, 0.5, px_m));
}

// Bark that correlates nowhere between views (leaves or their shadows across it) says nothing
// against a whole outline as wide as the cloud's points: such a fit stands. Swept over the
// outline's two-sided views, its rays' scatter, its width against the cloud's (narrower by the
// cloud's share and stereo's smear, wider by the share; a thin stem's cloud and a thick one's),
// and the bark's correlation and where it peaked; anything short of a whole, tight outline the
// cloud's width confirms, or bark that lines up best at the search's end, leaves the bark's
// verdict standing.
TEST(OutlineOutweighsPlainBark, OnlyAWholeTightOutlineAsWideAsTheCloudOutweighsPlainBark) {
  const MeasureOptions o;
  const double px_m = 0.006;
  for (double cloud_r : {0.13, 0.085}) {
    for (int two_sided : {6, 13, 14, 25}) {
      for (double rms_px : {0.5, 1.0, 1.5}) {
        for (double width : {0.4, 0.5, 0.6, 0.7, 0.85, 1.0, 1.15, 1.3}) {
          for (double ncc : {0.1, 0.25, 0.5}) {
            for (bool at_end : {false, true}) {
              TangentFit f;
              f.ok = true;
              f.tried_views = 27;
              f.two_sided_views = two_sided;
              f.rms_m = rms_px * px_m;
              f.radius_m = width * cloud_r;
              BarkDepth bark;
              bark.pairs = 40;
              bark.peak_ncc = ncc;
              bark.at_search_end = at_end;
              const bool whole = 2 * two_sided >= 27, tight = rms_px < 1.2;
              const bool as_wide = width <= 1.2 + 1e-9 &&
                                   width * cloud_r >= 0.8 * cloud_r - o.outline_over_bark_smear_m;
              const bool plain = ncc < o.bark_depth.min_surface_ncc && !at_end;
              EXPECT_EQ(OutlineOutweighsPlainBark(o, f, bark, f.centre, cloud_r, px_m),
                        whole && tight && as_wide && plain)
                  << "cloud r " << cloud_r << ", " << two_sided << " two-sided, " << rms_px
                  << " px, width " << width << ", ncc " << ncc << (at_end ? " at the end" : "");
            }
          }
        }
      }
    }
  }
  // Too few pairs compared: the bark check had nothing to say, and nothing to outweigh.
  const double cloud_r = 0.13;
  TangentFit f;
  f.ok = true;
  f.tried_views = f.two_sided_views = 20;
  f.rms_m = 0.5 * px_m;
  f.radius_m = cloud_r;
  BarkDepth bark;
  bark.pairs = o.bark_depth.min_pairs - 1;
  EXPECT_FALSE(OutlineOutweighsPlainBark(o, f, bark, f.centre, cloud_r, px_m));
}

// Stereo's smear widens a thin far stem's cloud and leaves its face where it is: an outline
// narrower than the cloud by more than its share (within outline_over_bark_smear_m) stands only
// with its face within StemOptions::max_depth_smear_m of the cloud's; one within the share
// stands whatever the gap (along the line of sight the cloud's depth is too rough to judge by).
// Swept over the faces' gap, nearer and farther.
TEST(OutlineOutweighsPlainBark, NarrowerByTheSmearOnlyWithItsFaceAtTheClouds) {
  const MeasureOptions o;
  const double px_m = 0.01, cloud_r = 0.089;
  const Eigen::Vector2d cloud(7.21, 2.36);
  const Eigen::Vector2d along = cloud.normalized();
  for (double radius_m : {0.064, 0.08}) {
    for (double gap_m : {-0.7, -0.4, -0.2, 0.0, 0.2, 0.4}) {
      TangentFit f;
      f.ok = true;
      f.tried_views = 48;
      f.two_sided_views = 42;
      f.rms_m = 0.3 * px_m;
      f.radius_m = radius_m;
      // The fit's face (centre's range less its radius) gap_m from the cloud's.
      f.centre = cloud + (gap_m + radius_m - cloud_r) * along;
      BarkDepth bark;
      bark.pairs = 61;
      bark.peak_ncc = 0.17;
      const bool within_share = radius_m >= (1 - o.outline_over_bark_cloud_share) * cloud_r;
      EXPECT_EQ(OutlineOutweighsPlainBark(o, f, bark, cloud, cloud_r, px_m),
                within_share || std::abs(gap_m) <= o.stems.max_depth_smear_m)
          << "radius " << radius_m << ", faces " << gap_m << " m apart";
    }
  }
}

// A circle around one side of a stem and what stands beside it (a nearer sapling hid the stem's
// other side) can show a whole, tight outline as wide as the stem, and no bark: it stands only
// where the cloud saw the stem, its centre off the cloud's by at most the cloud's radius across
// the line of sight. Along it, the cloud's depth is too rough to judge by. Swept over the shift.
TEST(OutlineOutweighsPlainBark, OnlyWhereTheCloudSawTheStem) {
  const MeasureOptions o;
  const double px_m = 0.004, cloud_r = 0.26;
  const Eigen::Vector2d cloud(-0.08, 5.86);
  const Eigen::Vector2d across(-1.0, 0.0), along = cloud.normalized();
  for (double shift_m : {0.0, 0.1, 0.2, 0.3, 0.45}) {
    for (bool sideways : {false, true}) {
      TangentFit f;
      f.ok = true;
      f.tried_views = 24;
      f.two_sided_views = 13;
      f.rms_m = 1.0 * px_m;
      f.radius_m = 0.21;
      f.centre = cloud + shift_m * (sideways ? across : along);
      BarkDepth bark;
      bark.pairs = 33;
      bark.peak_ncc = 0.07;
      EXPECT_EQ(OutlineOutweighsPlainBark(o, f, bark, cloud, cloud_r, px_m),
                !sideways || shift_m <= cloud_r)
          << shift_m << " m " << (sideways ? "across" : "along") << " the line of sight";
    }
  }
}

TEST(WideFitLinesUpOnBark, AFitWellOverTheCloudsWidthNeedsItsBark) {
  // A sapling's 8.8-cm part, whose widest start closed on 19.8 cm.
  const MeasureOptions o;
  TangentFit f;
  f.ok = true;
  f.radius_m = 0.099;
  BarkDepth bark;
  bark.pairs = 38;
  bark.peak_ncc = 0.38;
  EXPECT_FALSE(WideFitLinesUpOnBark(o, f, bark, 0.044));
  bark.peak_ncc = 0.955;  // a stem of which the cloud saw only a sliver: its bark lines up
  EXPECT_TRUE(WideFitLinesUpOnBark(o, f, bark, 0.044));
  bark.pairs = 0;  // no bark to compare: nothing shows the width
  EXPECT_FALSE(WideFitLinesUpOnBark(o, f, bark, 0.044));
  bark.peak_ncc = 0.38;
  EXPECT_TRUE(WideFitLinesUpOnBark(o, f, bark, 0.075));  // under 1.4 times the cloud's radius
  // A sapling's crown outlined around its few points, 1.6-1.8 times their width, its bark
  // correlating at 0.4-0.67: not a stem; a stem's bark lines up.
  for (const double times : {1.6, 1.8}) {
    for (const double ncc : {0.4, 0.67, 0.9}) {
      bark.pairs = 30;
      bark.peak_ncc = ncc;
      EXPECT_EQ(WideFitLinesUpOnBark(o, f, bark, f.radius_m / times), ncc >= 0.7)
          << times << " times, ncc " << ncc;
    }
  }
  bark.peak_ncc = 0.38;
  // Straight behind a listed stem the cloud saw a sliver: too few pairs to tell let the fit
  // stand; bark that fails to line up over enough pairs still does not.
  for (const int pairs : {0, o.bark_depth.min_pairs - 1}) {
    bark.pairs = pairs;
    EXPECT_TRUE(WideFitLinesUpOnBark(o, f, bark, 0.044, true)) << pairs;
  }
  bark.pairs = o.bark_depth.min_pairs;
  EXPECT_FALSE(WideFitLinesUpOnBark(o, f, bark, 0.044, true));
}

// Sharp (both sides in three views to half a pixel) or whole (both sides in half its views, on
// one circle to a couple of pixels, as a core must be to stand alone): listed.
TEST(AddLargerCloudOnlyStems, ListsWholeFitsThatAreNotSharp) {
  const MeasureOptions o;
  std::vector<Stem> kept;
  std::vector<Eigen::Vector3d> occluders;
  const std::vector<Stem> candidates = {Fitted(5.24, 5.29, 0.19, 0.0),   // whole, not sharp
                                        Fitted(-5.4, -7.5, 0.26, 0.0)};  // neither
  const int added = AddLargerCloudOnlyStems(
      o, candidates,
      [&](Stem s) {
        const bool whole = s.centre_xy.x() > 0;
        return RefinedStem{SilhouetteVerdict::kUse, std::move(s), whole, whole, false, false};
      },
      &kept, &occluders);
  EXPECT_EQ(added, 1);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_DOUBLE_EQ(kept[0].centre_xy.x(), 5.24);
  EXPECT_EQ(kept[0].flags.Names(), std::vector<std::string_view>{"silhouette_only"});
}

// Straight behind a listed stem, a fit whose sides show in views of their own (SidesSeenApart)
// is listed though neither sharp nor whole: the nearer stem hides one side from each end of the
// arm, so both sides seldom show in one view.
TEST(AddLargerCloudOnlyStems, ListsFitsBehindANearerStemWhoseSidesShowApart) {
  const MeasureOptions o;
  std::vector<Stem> kept = {Fitted(2.59, -0.68, 0.18, 0.0)};
  std::vector<Eigen::Vector3d> occluders = {{2.59, -0.68, 0.09}};
  const std::vector<Stem> candidates = {Fitted(3.93, -1.08, 0.236, 0.0),  // sides seen apart
                                        Fitted(5.9, -1.6, 0.2, 0.0)};     // neither
  const int added = AddLargerCloudOnlyStems(
      o, candidates,
      [&](Stem s) {
        const bool apart = s.centre_xy.x() < 5;
        return RefinedStem{
            SilhouetteVerdict::kUse, std::move(s), apart, false, false, false, apart};
      },
      &kept, &occluders);
  EXPECT_EQ(added, 1);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_DOUBLE_EQ(kept[1].centre_xy.x(), 3.93);
}

// A stem a nearer one hides a side of for part of the turn, its bark lining up on a fit that
// shows both sides in half the views where no nearer stem hid a side (an 18.8-cm stem 9.7 m out,
// 3.3 degrees off a 38.7-cm one 3.8 m out: both sides in 12 of 27 views, to 0.7 px): listed,
// though neither sharp nor whole over all its views; not where that is turned off, nor a sapling
// under min_dbh_cm found so (listed, it would stand as a nearer stem that a farther fit is
// straight behind: a 4.6-cm sapling 9.1 m out let a 26-cm circle behind it through).
TEST(AddLargerCloudOnlyStems, ListsFitsWholeWhereNoNearerStemHidesASide) {
  for (const bool on : {true, false}) {
    MeasureOptions o;
    o.larger_cloud_whole_where_open = on;
    std::vector<Stem> kept;
    std::vector<Eigen::Vector3d> occluders;
    const std::vector<Stem> candidates = {Fitted(1.61, -9.54, 0.18, 0.0),   // whole where open
                                          Fitted(8.55, 3.19, 0.05, 0.0),    // so, but a sapling
                                          Fitted(6.69, -7.06, 0.14, 0.0)};  // neither
    const int added = AddLargerCloudOnlyStems(
        o, candidates,
        [&](Stem s) {
          const bool open = s.centre_xy.x() < 6 || s.dbh_m < 0.1;
          RefinedStem r{SilhouetteVerdict::kUse, std::move(s), open, false, false, false, false};
          r.whole_where_open = open;
          return r;
        },
        &kept, &occluders);
    EXPECT_EQ(added, on ? 1 : 0);
    if (on) {
      ASSERT_EQ(kept.size(), 1u);
      EXPECT_DOUBLE_EQ(kept[0].centre_xy.x(), 1.61);
    }
  }
}

TEST(AddLargerCloudOnlyStems, ListsSharpFitsWhereNoStemStands) {
  const MeasureOptions o;
  std::vector<Stem> kept = {Fitted(-4.44, 1.24, 0.243, 0.0)};
  std::vector<Eigen::Vector3d> occluders = {{-4.44, 1.24, 0.12}};
  const std::vector<Stem> candidates = {
      Fitted(-4.40, 1.40, 0.1, 0.0),    // its circle touches the listed stem's: not tried
      Fitted(-8.11, 2.18, 0.107, 0.0),  // sharp: listed
      Fitted(-8.10, 2.20, 0.148, 0.0),  // now on the stem just listed: not tried
      Fitted(5.55, -8.20, 0.259, 0.0),  // fits, but loosely
      Fitted(6.0, 3.0, 0.2, 0.0)};      // sharp, but its fit is not used
  int tried = 0;
  const int added = AddLargerCloudOnlyStems(
      o, candidates,
      [&](Stem s) {
        ++tried;
        const bool sharp = s.centre_xy.x() < 0 || s.centre_xy.y() > 0;
        const bool use = s.centre_xy.y() < 2.5;
        return RefinedStem{use ? SilhouetteVerdict::kUse : SilhouetteVerdict::kDrop,
                           std::move(s),
                           true,
                           false,
                           false,
                           sharp};
      },
      &kept, &occluders);
  EXPECT_EQ(added, 1);
  EXPECT_EQ(tried, 3);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_DOUBLE_EQ(kept[1].centre_xy.x(), -8.11);
  EXPECT_EQ(kept[1].flags.Names(), std::vector<std::string_view>{"silhouette_only"});
  ASSERT_EQ(occluders.size(), 2u);
  EXPECT_DOUBLE_EQ(occluders[1].z(), 0.0535);
}

// A stem's larger cloud smeared along the line of sight is far wider than the stem: its circle
// may reach a listed stem beside it while its centre stands clear. It is tried; one whose centre
// lies on a listed stem is not. Swept over how far the smear reaches past the listed stem.
TEST(AddLargerCloudOnlyStems, TriesASmearedStemWhoseCircleReachesAListedOne) {
  const MeasureOptions o;
  for (double smeared_dbh_m : {0.3, 0.6, 0.9}) {
    std::vector<Stem> kept = {Fitted(10.06, 1.43, 0.126, 0.0)};
    std::vector<Eigen::Vector3d> occluders = {{10.06, 1.43, 0.063}};
    const std::vector<Stem> candidates = {Fitted(9.73, 1.37, smeared_dbh_m, 0.0),
                                          Fitted(10.10, 1.45, smeared_dbh_m, 0.0)};
    std::vector<double> tried_x;
    const int added = AddLargerCloudOnlyStems(
        o, candidates,
        [&](Stem s) {
          tried_x.push_back(s.centre_xy.x());
          s.centre_xy = {9.06, 1.11};  // its silhouettes fit the stem in front of the smear
          s.dbh_m = 0.246;
          return RefinedStem{SilhouetteVerdict::kUse, std::move(s), true, true};
        },
        &kept, &occluders);
    EXPECT_EQ(added, 1) << smeared_dbh_m;
    ASSERT_EQ(tried_x.size(), 1u) << smeared_dbh_m;
    EXPECT_DOUBLE_EQ(tried_x[0], 9.73);
  }
}

// Candidates the silhouettes' votes gave: tried where their circle (not only their centre) stays
// clear of every listed stem, at most max_tries of them; listed where their fit agrees with the
// votes though it is neither sharp nor whole.
TEST(AddStemsWithoutPart, VotedCandidatesClearOfListedStemsUpToTheirCount) {
  const MeasureOptions o;
  std::vector<Stem> kept = {Fitted(4.0, 0.0, 0.3, 0.0)};
  std::vector<Eigen::Vector3d> occluders = {{4.0, 0.0, 0.15}};
  const std::vector<Stem> candidates = {
      Fitted(4.4, 0.0, 0.2, 0.0),    // its circle comes within 0.3 m of the listed stem's
      Fitted(6.0, 2.0, 0.12, 0.0),   // agrees with its votes: listed
      Fitted(6.0, -2.0, 0.2, 0.0),   // neither agrees nor is whole
      Fitted(-6.0, 2.0, 0.2, 0.0)};  // past max_tries
  std::vector<double> tried_y;
  const int added = AddStemsWithoutPart(
      o, candidates, {0.3, true, 2},
      [&](Stem s) {
        tried_y.push_back(s.centre_xy.y());
        RefinedStem r{SilhouetteVerdict::kUse, std::move(s)};
        r.agrees_with_votes = r.stem.centre_xy.y() > 0;
        return r;
      },
      &kept, &occluders);
  EXPECT_EQ(added, 1);
  EXPECT_EQ(tried_y, (std::vector<double>{2.0, -2.0}));
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_EQ(kept[1].flags.Names(), std::vector<std::string_view>{"silhouette_only"});
}

// A stem without a part of its own whose fit is neither sharp nor whole is listed where the
// cloud's rays end on its fitted circle (a near stem whose part the free-space veto rejected).
TEST(AddStemsWithoutPart, ListsAFitOnTheCloudsSurface) {
  const MeasureOptions o;
  std::vector<Stem> kept;
  std::vector<Eigen::Vector3d> occluders;
  const std::vector<Stem> candidates = {Fitted(-1.0, 1.6, 0.3, 0.0),   // on the surface
                                        Fitted(5.0, -2.0, 0.2, 0.0)};  // rays pass it
  const int added = AddLargerCloudOnlyStems(
      o, candidates,
      [&](Stem s) {
        RefinedStem r{SilhouetteVerdict::kUse, std::move(s)};
        r.on_cloud_surface = r.stem.centre_xy.y() > 0;
        return r;
      },
      &kept, &occluders);
  EXPECT_EQ(added, 1);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_DOUBLE_EQ(kept[0].centre_xy.x(), -1.0);
  EXPECT_EQ(kept[0].flags.Names(), std::vector<std::string_view>{"silhouette_only"});
}

// A fit the bark rejected, with its silhouettes' counts (no side hidden in any view).
TangentFit RejectedFit(int rays, int two_sided_views, int tried_views) {
  TangentFit f;
  f.ok = false;
  f.rays = rays;
  f.two_sided_views = two_sided_views;
  f.tried_views = f.open_views = tried_views;
  return f;
}

// Bark that lines up `shift_m` off the circle it was measured on.
BarkDepth BarkLinesUp(double peak_ncc, double shift_m) {
  BarkDepth bark;
  bark.ok = true;
  bark.peak_ncc = peak_ncc;
  bark.shift_m = shift_m;
  return bark;
}

TEST(BarkConfirmsCloud, TwoSidedSilhouettesAndBarkOnTheCloudsCircle) {
  // A 16.4-cm stem in front of a 35.8-cm one 2 m behind it: the fit settled on the far stem,
  // where the bark did not line up; on the cloud's circle it does, 6 cm nearer.
  const Stem part;
  const TangentFit f = RejectedFit(49, 20, 49);
  const BarkDepth bark = BarkLinesUp(0.95, -0.056);
  EXPECT_TRUE(BarkConfirmsCloud(part, f, bark));
  // Rejections, one at a time: a fit that stood, too few two-sided views (a sapling's twigs),
  // a weakly supported part, bark that lines up nowhere or only at the end of its search.
  struct Case {
    const char* what;
    std::function<void(Stem*, TangentFit*, BarkDepth*)> change;
  };
  const std::vector<Case> cases = {
      {"fit ok", [](auto*, auto* fit, auto*) { fit->ok = true; }},
      {"two-sided in 7 of 45",
       [](auto*, auto* fit, auto*) {
         fit->two_sided_views = 7, fit->tried_views = fit->open_views = 45;
       }},
      {"no silhouette", [](auto*, auto* fit, auto*) { fit->rays = 0; }},
      {"weak support", [](auto* p, auto*, auto*) { p->weak_support = true; }},
      {"no bark", [](auto*, auto*, auto* b) { b->ok = false; }},
      {"bark at the end", [](auto*, auto*, auto* b) { b->at_search_end = true; }}};
  for (const Case& c : cases) {
    Stem p2 = part;
    TangentFit f2 = f;
    BarkDepth b2 = bark;
    c.change(&p2, &f2, &b2);
    EXPECT_FALSE(BarkConfirmsCloud(p2, f2, b2)) << c.what;
  }
}

// A stem just beside a nearer one: the nearer stem hides one of its sides in most views, so both
// show in few, and a fit resting on the other side alone drifts along the line of sight until the
// bark rejects it. Both sides in half the views where no side was hidden (and in three at least)
// still say a trunk stands there; a sapling's crown seen past nearer stems shows both in a few
// views among many. Swept over the views where no side was hidden.
TEST(BarkConfirmsCloud, ViewsWhereANearerStemHidesASideAreNotCounted) {
  const Stem part;
  TangentFit f = RejectedFit(30, 5, 25);
  const BarkDepth bark = BarkLinesUp(0.98, -0.025);
  for (const int open : {25, 14, 11, 10, 6}) {
    f.open_views = open;
    EXPECT_EQ(BarkConfirmsCloud(part, f, bark), open <= 10) << open << " views with no side hidden";
  }
  f.two_sided_views = 2;  // under three: a few pairs of edges also come from twigs
  f.open_views = 3;
  EXPECT_FALSE(BarkConfirmsCloud(part, f, bark));
}

// Straight behind a listed stem and no wider than it from the plot centre, sides shown one at a
// time keep a part on firm support on its cloud from sides_past_nearer_min_views views on (either
// side counts: each end of the arm shows its own); a weakly supported part, a part wider than the
// stem it is behind (a smear of that stem's points, whose sides would show past it together), or
// the rule off, never.
TEST(ShowsSidesPastNearerStem, CountsTheViewsOfEitherSideOnAPartOnFirmSupport) {
  MeasureOptions o;
  Stem nearer;
  nearer.centre_xy = {3.0, 0.0};
  nearer.dbh_m = 0.46;  // 4.4 degrees wide each side of its bearing
  const std::vector<Stem> listed = {nearer};
  Stem part;
  part.centre_xy = {7.0, 0.1};
  const double r = 0.2;
  const int n = o.sides_past_nearer_min_views;
  EXPECT_TRUE(ShowsSidesPastNearerStem(o, part, r, listed, {n, 0}));
  EXPECT_TRUE(ShowsSidesPastNearerStem(o, part, r, listed, {n - 2, 2}));
  EXPECT_FALSE(ShowsSidesPastNearerStem(o, part, r, listed, {n - 1, 0}));
  EXPECT_FALSE(ShowsSidesPastNearerStem(o, part, 0.6, listed, {n, 0}));  // 4.9 degrees
  EXPECT_FALSE(ShowsSidesPastNearerStem(o, part, r, {}, {n, 0}));
  part.weak_support = true;
  EXPECT_FALSE(ShowsSidesPastNearerStem(o, part, r, listed, {n, n}));
  part.weak_support = false;
  o.sides_past_nearer_min_views = 0;
  EXPECT_FALSE(ShowsSidesPastNearerStem(o, part, r, listed, {20, 20}));
}

TEST(DropStemsFittedTwice, DropsTheFitThatSlidOntoANearerStem) {
  // A 27.8-cm stem, and a 17.8-cm fit that moved 0.47 m from its points to touch it; a third
  // stem 0.46 m from the first, and a far one that moved as much, stay.
  std::vector<Stem> stems = {Fitted(4.42, 3.82, 0.278, 0.01), Fitted(4.24, 3.97, 0.178, 0.47),
                             Fitted(4.42, 4.12 + 0.16, 0.10, 0.02), Fitted(-6.0, 1.0, 0.30, 0.47)};
  EXPECT_EQ(DropStemsFittedTwice(0.02, &stems), 1);
  ASSERT_EQ(stems.size(), 3u);
  EXPECT_DOUBLE_EQ(stems[0].dbh_m, 0.278);
  EXPECT_DOUBLE_EQ(stems[1].dbh_m, 0.10);
  EXPECT_DOUBLE_EQ(stems[2].centre_xy.x(), -6.0);
}

// One stem measured twice: a fit resting on one side (or the cloud's width), read 2-5 times too
// wide where the seen side was a leaf's edge, its centre pushed back by the extra radius; and a
// two-sided fit of the stem's own width whose candidate's points lay 0.3-1.0 m off. Whichever
// moved farther, the two-sided fit stays.
TEST(DropStemsFittedTwice, AWidthMeasuredOnBothSidesOutlivesOneRestingOnOneSide) {
  for (const StemFlag weak : {StemFlag::kOneSided, StemFlag::kNoSilhouette}) {
    for (double dbh_m : {0.12, 0.2, 0.35}) {
      for (double wider : {2.0, 3.0, 5.0}) {
        for (double moved_m : {0.3, 0.6, 1.0}) {
          const double d = 8.5, extra = 0.5 * dbh_m * (wider - 1);
          Stem one_side = Fitted(-(d + extra), 0.0, wider * dbh_m, 0.1);
          one_side.flags.Set(weak);
          std::vector<Stem> stems = {one_side, Fitted(-d, 0.03, dbh_m, moved_m)};
          EXPECT_EQ(DropStemsFittedTwice(0.02, &stems), 1);
          ASSERT_EQ(stems.size(), 1u);
          EXPECT_DOUBLE_EQ(stems[0].dbh_m, dbh_m)
              << FlagName(weak) << " " << dbh_m << " x" << wider << " moved " << moved_m;
        }
      }
    }
  }
  // Both resting on one side: the farther-moved one goes, as between two two-sided fits.
  std::vector<Stem> stems = {Fitted(-8.8, 0.0, 0.5, 0.1), Fitted(-8.5, 0.03, 0.2, 0.6)};
  for (Stem& s : stems) s.flags.Set(StemFlag::kOneSided);
  EXPECT_EQ(DropStemsFittedTwice(0.02, &stems), 1);
  ASSERT_EQ(stems.size(), 1u);
  EXPECT_DOUBLE_EQ(stems[0].dbh_m, 0.5);
}

TEST(DropStemsFittedTwice, OfTwoEquallyMovedStemsOneStays) {
  std::vector<Stem> stems = {Fitted(5.0, 0.0, 0.30, 0.0), Fitted(5.0, 0.30, 0.30, 0.0)};
  EXPECT_EQ(DropStemsFittedTwice(0.02, &stems), 1);
  EXPECT_EQ(stems.size(), 1u);
}

// Three stems nearly in line from the centre, which depth noise joined into one 43-cm part with
// two dense cores; the part's silhouettes fit a 22.6-cm stem between them. `fitting` says which
// cores fit cleanly on their own.
struct InLine {
  Stem part;
  std::vector<Eigen::Vector2d> fitting;
  int refined = 0;
  InLine() {
    part.centre_xy = {8.8, -0.3};
    part.dbh_slice_m = 0.43;
    part.alternatives = {Fitted(8.2, -0.1, 0.17, 0.0), Fitted(9.1, -0.5, 0.13, 0.0)};
  }
  RefinedStem Refine(Stem s) {
    ++refined;
    const bool is_part = (s.centre_xy - part.centre_xy).norm() < 1e-9;
    const bool fits = is_part || std::ranges::any_of(fitting, [&](const Eigen::Vector2d& c) {
                        return (c - s.centre_xy).norm() < 1e-9;
                      });
    if (is_part) s.dbh_m = s.dbh_tangent_m = part_fit_dbh_m;
    const bool whole = fits && (!is_part || part_whole);
    return {fits ? SilhouetteVerdict::kUse : SilhouetteVerdict::kDrop, std::move(s), fits, whole};
  }
  double part_fit_dbh_m = 0.226;
  bool part_whole = true;  // the part's fit shows both sides in most views
};

// The InLine part with its cores' faces `apart_m` apart in range (each core's face is where its
// circle's near side would be).
Stem WithCoreFacesApart(Stem part, double apart_m) {
  Stem& nearer = part.alternatives[0];
  Stem& farther = part.alternatives[1];
  nearer.face_range_m = nearer.centre_xy.norm() - 0.5 * nearer.dbh_m;
  farther.face_range_m = nearer.face_range_m + apart_m;
  return part;
}

TEST(ResolvePart, AFitFarNarrowerThanASmearedPartGivesWayToItsCores) {
  InLine c;
  c.fitting = {{8.2, -0.1}, {9.1, -0.5}};
  std::vector<Stem> kept;
  const PartOutcome out = ResolvePart(
      {}, c.part, [&](Stem s) { return c.Refine(std::move(s)); }, &kept);
  ASSERT_EQ(kept.size(), 2u);
  EXPECT_DOUBLE_EQ(kept[0].dbh_m, 0.17);
  EXPECT_DOUBLE_EQ(kept[1].dbh_m, 0.13);
  EXPECT_EQ(out.fitted, 2);
  EXPECT_EQ(out.from_cores, 2);
}

TEST(ResolvePart, APartThatComesToNothingGivesWayToTheLargerCloudsClean) {
  // A sliver of a stem the silhouettes drop; the larger cloud's part of it fits cleanly, or not.
  // On its cloud only where the silhouettes agree with the cloud's width.
  for (const auto& [clean, agrees] : {std::pair{true, true}, {false, true}, {true, false}}) {
    Stem part = Fitted(4.99, -4.49, 0.188, 0.0);
    part.larger_cloud_part = {Fitted(4.98, -4.58, 0.308, 0.0)};
    std::vector<Stem> kept;
    const PartOutcome out = ResolvePart(
        {}, part,
        [&](Stem s) {
          const bool larger = s.dbh_m > 0.3;
          return RefinedStem{larger ? SilhouetteVerdict::kKeepCloud : SilhouetteVerdict::kDrop,
                             std::move(s), larger && clean, false, larger && agrees};
        },
        &kept);
    if (clean && agrees) {
      ASSERT_EQ(kept.size(), 1u);
      EXPECT_DOUBLE_EQ(kept[0].dbh_m, 0.308);
      EXPECT_EQ(out.fitted, 1);
      EXPECT_EQ(out.dropped, 0);
    } else {
      EXPECT_TRUE(kept.empty());
      EXPECT_EQ(out.dropped, 1);
    }
  }
}

TEST(ResolvePart, OneCoreAloneDoesNotReplaceThePartsFit) {
  InLine c;
  c.fitting = {{8.2, -0.1}};
  std::vector<Stem> kept;
  const PartOutcome out = ResolvePart(
      {}, c.part, [&](Stem s) { return c.Refine(std::move(s)); }, &kept);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_DOUBLE_EQ(kept[0].dbh_m, 0.226);
  EXPECT_EQ(out.fitted, 1);
  EXPECT_EQ(out.from_cores, 0);
}

// ... unless the part's fit shows both sides in only some views and that core in most of its
// own: the part's fit then caught what stands beside the stem.
TEST(ResolvePart, OneWholeCoreReplacesAPartialFitOfItsPart) {
  InLine c;
  c.fitting = {{8.2, -0.1}};
  c.part_whole = false;
  std::vector<Stem> kept;
  const PartOutcome out = ResolvePart(
      {}, c.part, [&](Stem s) { return c.Refine(std::move(s)); }, &kept);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_DOUBLE_EQ(kept[0].dbh_m, 0.17);
  EXPECT_EQ(out.fitted, 1);
  EXPECT_EQ(out.from_cores, 1);
}

// What the silhouettes say of a part and its two cores where one core is a sliver that fits
// nothing and the other outlines the same stem as the part: each fit (its circle, DBH and
// two-sided views of `tried_views`) whole and clean.
struct PartWithOneCoreOverIt {
  Eigen::Vector2d part_centre, sliver_centre;
  Eigen::Vector2d part_fit_centre, core_fit_centre;
  double part_fit_dbh_m, core_fit_dbh_m;
  int tried_views, part_two_sided, core_two_sided;
  RefinedStem operator()(Stem s) const {
    const bool is_part = (s.centre_xy - part_centre).norm() < 1e-9;
    if ((s.centre_xy - sliver_centre).norm() < 1e-9) {
      return RefinedStem{SilhouetteVerdict::kDrop, std::move(s)};
    }
    s.centre_xy = is_part ? part_fit_centre : core_fit_centre;
    s.dbh_m = s.dbh_tangent_m = is_part ? part_fit_dbh_m : core_fit_dbh_m;
    s.evidence.tried_views = tried_views;
    s.evidence.two_sided_views = is_part ? part_two_sided : core_two_sided;
    return RefinedStem{SilhouetteVerdict::kUse, std::move(s), true, true};
  }
};

// A part smeared wide (33 cm) whose own fit, a 17.6-cm circle inside the stem, shows both sides
// in 12 of 23 views, and whose core's fit, a 30-cm circle over it, in more or fewer: both
// outline one stem, and the one that shows both sides in more of its views stands. A second
// core (a sliver) fits nothing. Swept over the core's two-sided views.
TEST(ResolvePart, OfAPartsFitAndAWholeCoreOverItTheOneTwoSidedInMoreViewsStands) {
  for (const int core_two_sided : {12, 13, 17, 21, 23}) {
    Stem part = Fitted(7.32, 2.25, 0.0, 0.0);
    part.dbh_slice_m = 0.332;
    part.alternatives = {Fitted(7.03, 2.29, 0.0, 0.0), Fitted(7.29, 2.53, 0.0, 0.0)};
    const PartWithOneCoreOverIt refine{part.centre_xy, {7.29, 2.53}, {7.14, 2.24}, {7.15, 2.30},
                                       0.176,          0.30,         23,           12,
                                       core_two_sided};
    std::vector<Stem> kept;
    const PartOutcome out = ResolvePart({}, part, refine, &kept);
    const bool core_stands = core_two_sided > 12;
    ASSERT_EQ(kept.size(), 1u) << core_two_sided << " two-sided views";
    EXPECT_DOUBLE_EQ(kept[0].dbh_m, core_stands ? 0.30 : 0.176) << core_two_sided;
    EXPECT_EQ(out.from_cores, core_stands ? 1 : 0) << core_two_sided;
  }
}

TEST(OutlinesTheStemInMoreViews, OverlappingAndTwoSidedInALargerShareOfItsViews) {
  Stem core = Fitted(7.15, 2.30, 0.30, 0.0), fit = Fitted(7.14, 2.24, 0.176, 0.0);
  core.evidence.tried_views = 20;
  core.evidence.two_sided_views = 15;
  fit.evidence.tried_views = 23;
  fit.evidence.two_sided_views = 12;
  EXPECT_TRUE(OutlinesTheStemInMoreViews(core, fit));
  EXPECT_FALSE(OutlinesTheStemInMoreViews(fit, core));
  core.evidence.two_sided_views = 10;  // 0.50 of its views against 0.52
  EXPECT_FALSE(OutlinesTheStemInMoreViews(core, fit));
  core.evidence.two_sided_views = 15;
  core.centre_xy = {7.14, 2.55};  // 0.31 m apart, radii 0.24 m together: two stems
  EXPECT_FALSE(OutlinesTheStemInMoreViews(core, fit));
  core.centre_xy = {7.15, 2.30};
  core.evidence = {};  // no silhouette fit
  EXPECT_FALSE(OutlinesTheStemInMoreViews(core, fit));
}

// Two cores of one stem overlap: the one with both sides in most of its views stands, though it
// comes second.
TEST(ResolvePart, OfOverlappingCoresTheWholeOneStands) {
  Stem part = Fitted(8.6, -0.2, 0.0, 0.0);
  part.dbh_slice_m = 0.43;
  part.alternatives = {Fitted(8.5, -0.2, 0.10, 0.0), Fitted(8.55, -0.15, 0.19, 0.0)};
  auto refine = [&](Stem s) {
    const bool is_part = s.dbh_m == 0.0;
    if (is_part) s.dbh_m = s.dbh_tangent_m = 0.14;
    const bool whole = s.dbh_m == 0.19;
    return RefinedStem{SilhouetteVerdict::kUse, std::move(s), true, whole};
  };
  std::vector<Stem> kept;
  const PartOutcome out = ResolvePart({}, part, refine, &kept);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_DOUBLE_EQ(kept[0].dbh_m, 0.19);
  EXPECT_EQ(out.from_cores, 1);
}

// Two cores of a part kept on its cloud, both showing both sides in most of their views, overlap:
// a narrow one (a pair of lines on the stem's bark, or the stem's outline mixed with a farther
// stem's edge beside it) and a wider one. The one with both sides in more views stands,
// whichever comes first.
TEST(ResolvePart, OfOverlappingWholeCoresTheOneTwoSidedInMoreViewsStands) {
  for (const bool narrow_first : {true, false}) {
    Stem part = Fitted(7.9, 2.6, 0.0, 0.0);
    part.dbh_slice_m = 0.34;
    Stem narrow = Fitted(7.92, 2.52, 0.14, 0.0), wide = Fitted(7.92, 2.69, 0.28, 0.0);
    narrow.evidence.two_sided_views = 21;
    wide.evidence.two_sided_views = 27;
    part.alternatives = narrow_first ? std::vector{narrow, wide} : std::vector{wide, narrow};
    auto refine = [&](Stem s) {
      if (s.dbh_m == 0.0) {
        s.dbh_m = 0.34;  // kept on the cloud
        return RefinedStem{SilhouetteVerdict::kKeepCloud, std::move(s), false, false};
      }
      return RefinedStem{SilhouetteVerdict::kUse, std::move(s), true, true};
    };
    std::vector<Stem> kept;
    const PartOutcome out = ResolvePart({}, part, refine, &kept);
    SCOPED_TRACE(narrow_first ? "the narrow core first" : "the wide core first");
    ASSERT_EQ(kept.size(), 1u);
    EXPECT_DOUBLE_EQ(kept[0].dbh_m, 0.28);
    EXPECT_EQ(out.from_cores, 1);
  }
}

// A part kept on its cloud's width (its own fit neither near it nor two-sided in most views),
// with one core under min_core_share of that width: stereo smeared a stem 1.5-1.7 times wide,
// and the core is the stem when its own silhouettes show both sides in most of its views; a
// core without such an outline is a piece of the bark and the part stands. Swept over the
// core's share of the part's width.
TEST(ResolvePart, AWholeCoreReplacesAPartKeptOnItsSmearedWidth) {
  for (double share : {0.35, 0.5, 0.59}) {
    for (bool core_whole : {true, false}) {
      Stem part = Fitted(4.2, 7.55, 0.0, 0.0);
      part.dbh_slice_m = 0.436;
      part.alternatives = {Fitted(4.36, 7.54, share * 0.436, 0.0)};
      auto refine = [&](Stem s) {
        const bool is_part = s.dbh_m == 0.0;
        if (is_part) {
          s.dbh_m = 0.436;  // kept on the cloud
          return RefinedStem{SilhouetteVerdict::kKeepCloud, std::move(s), false, false};
        }
        return RefinedStem{SilhouetteVerdict::kUse, std::move(s), true, core_whole};
      };
      std::vector<Stem> kept;
      const PartOutcome out = ResolvePart({}, part, refine, &kept);
      ASSERT_EQ(kept.size(), 1u);
      EXPECT_DOUBLE_EQ(kept[0].dbh_m, core_whole ? share * 0.436 : 0.436)
          << "core " << share << " of the part, " << (core_whole ? "whole" : "not whole");
      EXPECT_EQ(out.from_cores, core_whole ? 1 : 0);
    }
  }
}

// A core of a part no stem as a whole (a shrub's, a sapling crown's, or a stem's) stands on clean
// silhouettes only, as a part's core does: a fit the verdict uses is not enough.
TEST(ResolvePart, ACoreOfAPartNoStemAsAWholeNeedsCleanSilhouettes) {
  for (const bool clean : {false, true}) {
    for (const bool mixed : {false, true}) {
      Stem part = Fitted(0.12, -8.89, 0.106, 0.0);
      part.weak_support = true;
      part.mixed_part_core = mixed;
      auto refine = [&](Stem s) {
        s.dbh_m = 0.135;
        return RefinedStem{SilhouetteVerdict::kUse, std::move(s), clean};
      };
      std::vector<Stem> kept;
      const PartOutcome out = ResolvePart({}, part, refine, &kept);
      const bool stands = clean || !mixed;
      EXPECT_EQ(kept.size(), stands ? 1u : 0u) << "clean " << clean << ", mixed " << mixed;
      EXPECT_EQ(out.dropped, stands ? 0 : 1);
    }
  }
}

TEST(ResolvePart, AFitNearThePartsWidthKeepsThePartWithoutTryingItsCores) {
  InLine c;
  c.fitting = {{8.2, -0.1}, {9.1, -0.5}};
  c.part_fit_dbh_m = 0.40;
  c.part = WithCoreFacesApart(c.part, 0.1);
  std::vector<Stem> kept;
  ResolvePart(
      {}, c.part, [&](Stem s) { return c.Refine(std::move(s)); }, &kept);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_DOUBLE_EQ(kept[0].dbh_m, 0.40);
  EXPECT_EQ(c.refined, 1);
}

// Cores whose faces lie farther apart in range than the wider core's width and the depth smear
// (0.17 + 0.3 m here) are no one stem's surface, whatever the part's fit: from 0.5 m to 2 m
// apart, the part's fit about as wide as the part (it runs from the nearer stem's outer side to
// the farther one's) gives way to the two cores that fit on their own. Nearer together in range
// (one stem's face and its smear), or with the rule off, the part's fit stands untried.
TEST(ResolvePart, CoresOneBehindAnotherReplaceAFitAsWideAsTheirPart) {
  for (const double apart_m : {0.0, 0.2, 0.45, 0.5, 0.8, 1.2, 2.0}) {
    for (const bool rule : {true, false}) {
      SCOPED_TRACE(::testing::Message() << "faces " << apart_m << " m apart, rule " << rule);
      InLine c;
      c.fitting = {{8.2, -0.1}, {9.1, -0.5}};
      c.part_fit_dbh_m = 0.40;
      c.part = WithCoreFacesApart(c.part, apart_m);
      MeasureOptions o;
      o.try_cores_one_behind_another = rule;
      std::vector<Stem> kept;
      const PartOutcome out = ResolvePart(
          o, c.part, [&](Stem s) { return c.Refine(std::move(s)); }, &kept);
      const bool apart = rule && apart_m > 0.17 + o.stems.max_depth_smear_m;
      EXPECT_EQ(CoresOneBehindAnother(o.stems.max_depth_smear_m, c.part.alternatives),
                apart_m > 0.17 + o.stems.max_depth_smear_m);
      ASSERT_EQ(kept.size(), apart ? 2u : 1u);
      EXPECT_EQ(out.from_cores, apart ? 2 : 0);
      EXPECT_DOUBLE_EQ(kept[0].dbh_m, apart ? 0.17 : 0.40);
      EXPECT_EQ(c.refined, apart ? 3 : 1);
    }
  }
}

// ... and where fewer than two of those cores fit on their own, the part's fit stands.
TEST(ResolvePart, OneCoreOfTwoOneBehindAnotherLeavesThePartsFit) {
  InLine c;
  c.fitting = {{8.2, -0.1}};
  c.part_fit_dbh_m = 0.40;
  c.part = WithCoreFacesApart(c.part, 1.0);
  std::vector<Stem> kept;
  ResolvePart(
      {}, c.part, [&](Stem s) { return c.Refine(std::move(s)); }, &kept);
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_DOUBLE_EQ(kept[0].dbh_m, 0.40);
}

// ... nor where the one core that fits outlines the stem too, inside the part's fit and both
// sides in more of its views (a far stem smeared in depth, whose cloud gave cores at ranges apart,
// and a circle following the shading across its bark): stems one behind another are two, and the
// part's fit, as wide as the part, stands. Swept over the core's two-sided views. (The same core
// replaces a fit far narrower than its part: OfAPartsFitAndAWholeCoreOverItTheOneTwoSidedInMore-
// ViewsStands.)
TEST(ResolvePart, OneCoreOverThePartsFitOfCoresOneBehindAnotherLeavesThePartsFit) {
  for (const int core_two_sided : {15, 19, 25}) {
    SCOPED_TRACE(::testing::Message() << "core two-sided in " << core_two_sided << " views");
    Stem part = WithCoreFacesApart(InLine().part, 1.0);
    const PartWithOneCoreOverIt refine{part.centre_xy, {8.2, -0.1}, {8.8, -0.3}, {8.82, -0.31},
                                       0.32,           0.23,        25,          14,
                                       core_two_sided};
    std::vector<Stem> kept;
    const PartOutcome out = ResolvePart({}, part, refine, &kept);
    ASSERT_EQ(kept.size(), 1u);
    EXPECT_DOUBLE_EQ(kept[0].dbh_m, 0.32);
    EXPECT_EQ(out.from_cores, 0);
  }
}

// A silhouette is jagged where its bands stray from its line by more than both a centimetre and
// 1.2 px at the stem; two thirds of a fit's silhouettes jagged make it leaves, except straight
// behind a listed stem.
TEST(LeafyOutline, TwoThirdsOfTheSilhouettesJaggedAreLeaves) {
  const MeasureOptions o;
  auto fit_with = [](std::vector<double> scatter_m) {
    TangentFit f;
    f.ok = true;
    for (const double m : scatter_m) {
      TangentFit::Ray ray;
      ray.edge_scatter_m = m;
      f.silhouettes.push_back(ray);
    }
    return f;
  };
  const double px_m = 0.004;  // a stem 6 m out at 1 500 px focal length
  // A trunk: a few millimetres of bark relief; one side beside leaves in half the views.
  EXPECT_EQ(JaggedSilhouetteShare(o, fit_with({0.002, 0.004, 0.003, 0.005}), px_m), 0.0);
  EXPECT_FALSE(LeafyOutline(o, fit_with({0.002, 0.02, 0.003, 0.03, 0.004, 0.025}), px_m));
  // A crown: jagged by centimetres in most views.
  const TangentFit crown = fit_with({0.03, 0.02, 0.015, 0.004, 0.04, 0.025});
  EXPECT_NEAR(JaggedSilhouetteShare(o, crown, px_m), 5.0 / 6.0, 1e-12);
  EXPECT_TRUE(LeafyOutline(o, crown, px_m));
  // Far out, a centimetre is under the edges' noise of 1.2 px: not jagged.
  EXPECT_FALSE(LeafyOutline(o, crown, /*px_m=*/0.04));
  // Straight behind a listed stem, silhouettes along its outline scatter with it: not leaves
  // for that (the stem must show past the nearer one instead).
  EXPECT_FALSE(LeafyOutline(o, crown, px_m, /*straight_behind_nearer=*/true));
  // Off; and no silhouettes, nothing jagged.
  MeasureOptions off;
  off.leafy_edge_share = 0;
  EXPECT_FALSE(LeafyOutline(off, crown, px_m));
  EXPECT_FALSE(LeafyOutline(o, TangentFit(), px_m));
}

TEST(JudgeSilhouetteFit, UsesAFitThatAgreesWithTheCloud) {
  const Case c;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
}

TEST(JudgeSilhouetteFit, KeepsTheCloudWhenTheFitLockedOntoSomethingElse) {
  Case c;
  // Under narrow_min_share (0.35) of the points' width: a furrow or a neighbour's edge.
  c.fit.radius_m = 0.045;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
}

// A fit narrower than the points, within the cloud's tolerance, is used while its rays agree to
// a few pixels; once they scatter beyond loose_fit_rms_px it is no stem's outline and the
// points' width stands. Swept over the narrowing and the scatter.
TEST(JudgeSilhouetteFit, ALooseNarrowerFitKeepsTheCloudWhateverTheNarrowing) {
  const MeasureOptions o;
  for (double share : {0.7, 0.8, 0.9, 0.97}) {
    for (double rms_px : {0.5, 2.0, 2.9, 3.2, 5.0, 8.0}) {
      Case c;
      c.fit.radius_m = share * 0.15;
      c.fit.rms_m = rms_px * c.px_m;
      c.fit.two_sided_views = 2;  // neither two-sided rule applies: the cloud's tolerance does
      const SilhouetteVerdict want =
          rms_px > o.loose_fit_rms_px ? SilhouetteVerdict::kKeepCloud : SilhouetteVerdict::kUse;
      EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, c.px_m), want)
          << "share " << share << " rms " << rms_px << " px";
    }
  }
}

// A fit wider than the points whose rays agree less tightly than a pixel counts as the cloud's
// width only up to loose_wider_max_over_cloud of it: beyond, its edges lie beside the stem (a
// farther stem's outline next to one side in some views) and the points' width stands; agreeing
// to a pixel with both sides in three views it stands as any wider fit. Swept over the widening
// and the scatter.
TEST(JudgeSilhouetteFit, ALooseFitFarWiderThanThePointsKeepsTheCloud) {
  const MeasureOptions o;
  for (double share : {1.05, 1.15, 1.22, 1.28, 1.34}) {
    for (double rms_px : {0.5, 1.0, 1.5, 2.0, 2.9}) {
      Case c;
      c.fit.radius_m = share * 0.15;
      c.fit.rms_m = rms_px * c.px_m;
      const bool tight = rms_px < o.tight_fit_rms_px;
      const SilhouetteVerdict want = tight || share < o.loose_wider_max_over_cloud
                                         ? SilhouetteVerdict::kUse
                                         : SilhouetteVerdict::kKeepCloud;
      EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, c.px_m), want)
          << "share " << share << " rms " << rms_px << " px";
    }
  }
}

// The same scatter on a fit wider than the points does not touch the narrower-fit rule.
TEST(JudgeSilhouetteFit, ALooseWiderFitIsJudgedByTheOtherRules) {
  Case c;
  c.fit.radius_m = 0.165;
  c.fit.rms_m = 5.0 * c.px_m;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
}

TEST(JudgeSilhouetteFit, APartWithoutSilhouettesIsDroppedUnlessUnconfirmedPartsAreKept) {
  Case c;
  c.fit.ok = false;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kDrop);
  MeasureOptions keep;
  keep.require_silhouette = false;
  EXPECT_EQ(JudgeSilhouetteFit(keep, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
}

TEST(JudgeSilhouetteFit, NarrowerSilhouettesOnBothSidesInMostViewsOutrankTheCloud) {
  Case c;
  c.fit.radius_m = 0.08;  // the cloud took in a shrub beside a 16-cm stem
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.fit.radius_m = 0.06;  // saplings on both sides of a 12-cm stem: 0.4 of the points' width
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.stem.depth_smeared = true;  // also where the stereo points were smeared in depth
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.stem.depth_smeared = false;
  c.fit.tried_views = 8;  // both sides in only three of eight views: not enough to overrule it
  c.fit.two_sided_views = 3;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
}

// A part on weak support (a core of a part too wide for one stem, a thinly seen far stem) needs
// its silhouettes to confirm it: both sides in three views on one circle to about a pixel, or,
// where its bark lines up on the fit, both sides in half the views to weak_on_bark_max_rms_px (a
// thick stem's outline scatters more than a pixel). Swept over the scatter and the two-sided
// share, with and without the bark.
TEST(JudgeSilhouetteFit, AWeakPartIsConfirmedByAWholeOutlineWhereItsBarkLinesUp) {
  const MeasureOptions o;
  for (double rms_px : {0.5, 1.5, 1.9, 2.5}) {
    for (int two_sided : {2, 8, 12}) {
      for (bool bark : {false, true}) {
        Case c;
        c.stem.weak_support = true;
        c.fit.tried_views = c.fit.views = 20;
        c.fit.two_sided_views = two_sided;
        c.fit.rms_m = rms_px * c.px_m;
        const bool tight = two_sided >= 3 && rms_px < 1.2;
        const bool whole_on_bark =
            bark && 2 * two_sided >= 20 && rms_px < o.weak_on_bark_max_rms_px;
        const SilhouetteVerdict want =
            tight || whole_on_bark ? SilhouetteVerdict::kUse : SilhouetteVerdict::kDrop;
        EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, c.px_m, bark), want)
            << rms_px << " px, two-sided in " << two_sided << " of 20, bark " << bark;
      }
    }
  }
}

// A stem's breast-height points as stereo gives them: its face seen from the plot centre (the
// surface within 75 degrees of the line of sight), a point every 2 mm of bark, each off in range
// by up to `noise_m`.
std::vector<Eigen::Vector2d> BarkArc(const Eigen::Vector2d& centre, double radius_m, double noise_m,
                                     std::mt19937* rng) {
  std::uniform_real_distribution<double> jitter(-noise_m, noise_m);
  const double toward = std::atan2(-centre.y(), -centre.x());
  const double arc = 75.0 * M_PI / 180.0;
  const int n = std::max(8, static_cast<int>(2 * arc * radius_m / 0.002));
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < n; ++i) {
    const double a = toward - arc + 2 * arc * i / (n - 1);
    const Eigen::Vector2d p = centre + radius_m * Eigen::Vector2d(std::cos(a), std::sin(a));
    pts.push_back(p * (1 + jitter(*rng) / p.norm()));
  }
  return pts;
}

// The circle of `share` of a stem's radius inside it whose left outline (seen from the plot
// centre) is the stem's own and whose face lies on the stem's bark: a line on the bark (where
// sunlit bark meets shaded) and the true outline tangent to it.
TangentFit CircleInsideStem(const Eigen::Vector2d& stem_xy, double stem_radius_m, double share) {
  const double r = share * stem_radius_m, d = stem_xy.norm();
  const double left = std::atan2(stem_xy.y(), stem_xy.x()) + std::asin(stem_radius_m / d);
  double range_m = d;  // of the inner circle's centre, solved for in a few rounds
  Eigen::Vector2d c;
  for (int i = 0; i < 20; ++i) {
    const double bearing = left - std::asin(r / range_m);
    const Eigen::Vector2d dir(std::cos(bearing), std::sin(bearing));
    // Where the line of sight along `bearing` meets the stem's face.
    const double along = dir.dot(stem_xy);
    const double across2 = stem_xy.squaredNorm() - along * along;
    range_m = along - std::sqrt(std::max(0.0, stem_radius_m * stem_radius_m - across2)) + r;
    c = range_m * dir;
  }
  TangentFit f;
  f.ok = true;
  f.centre = c;
  f.radius_m = r;
  return f;
}

// A circle inside a stem, between a line on its bark and one true outline, has the stem's own
// points going on past its other outline at its face's range; the stem's circle has none past
// either. Swept over the stem's width and distance and the inner circle's share of it.
TEST(BarkPastOutlineShare, ACircleInsideAStemHasItsBarkPastOneOutline) {
  const MeasureOptions o;
  std::mt19937 rng(7);
  for (const double dbh_cm : {20.0, 27.0, 40.0}) {
    for (const double distance_m : {4.0, 7.0, 10.0}) {
      const Eigen::Vector2d xy(distance_m * std::cos(0.4), distance_m * std::sin(0.4));
      const double radius_m = 0.005 * dbh_cm;
      const std::vector<Eigen::Vector2d> bark = BarkArc(xy, radius_m, 0.01, &rng);
      EXPECT_LT(BarkPastOutlineShare(bark, xy, radius_m), 0.02) << dbh_cm << " cm";
      for (const double share : {0.4, 0.5, 0.6, 0.7}) {
        const TangentFit inner = CircleInsideStem(xy, radius_m, share);
        EXPECT_GE(BarkPastOutlineShare(bark, inner.centre, inner.radius_m),
                  o.narrower_max_bark_past_outline)
            << dbh_cm << " cm at " << distance_m << " m, inner circle " << share;
      }
    }
  }
}

// A stem inside a part its leaves (or a shrub's) widen: the leaves fill a volume around it,
// scattered in range, and few of them lie at its face's range past its outline. Swept over the
// stem's width, the part's, and how many leaf points there are for each of bark, several seeds.
TEST(BarkPastOutlineShare, LeavesAroundAStemSeldomLieAtItsFacePastItsOutline) {
  const MeasureOptions o;
  for (const double dbh_cm : {8.0, 12.0, 18.0}) {
    for (const double part_m : {0.3, 0.45, 0.6}) {
      for (const double leaves_per_bark : {0.5, 1.0, 2.0}) {
        for (const unsigned seed : {1u, 2u, 3u}) {
          std::mt19937 rng(seed);
          const Eigen::Vector2d xy(6.0, 1.0);
          const double radius_m = 0.005 * dbh_cm;
          std::vector<Eigen::Vector2d> pts = BarkArc(xy, radius_m, 0.01, &rng);
          std::uniform_real_distribution<double> across(-0.5 * part_m, 0.5 * part_m);
          const size_t leaves = static_cast<size_t>(leaves_per_bark * pts.size());
          for (size_t i = 0; i < leaves; ++i) {
            pts.push_back(xy + Eigen::Vector2d(across(rng), across(rng)));
          }
          EXPECT_LT(BarkPastOutlineShare(pts, xy, radius_m), o.narrower_max_bark_past_outline)
              << dbh_cm << " cm stem in a " << part_m << " m part, " << leaves_per_bark
              << " leaf points a bark point, seed " << seed;
        }
      }
    }
  }
}

// A narrower fit two-sided in every view, on one circle to a fraction of a pixel, its bark
// lining up: taken over the cloud's width where it outlines the stem inside its leaves, not
// where it lies inside the stem (narrower_max_bark_past_outline; with the rule off it was).
// Swept over the inner circle's share of the stem and the stem's distance.
TEST(JudgeSilhouetteFit, ANarrowerCircleInsideAStemIsNotTaken) {
  MeasureOptions off;
  off.narrower_max_bark_past_outline = 0;
  for (const double distance_m : {5.0, 8.0}) {
    for (const double share : {0.4, 0.5, 0.6}) {
      std::mt19937 rng(3);
      Case c;
      c.stem.centre_xy = {distance_m, 0.0};
      c.stem.slice_xy = BarkArc(c.stem.centre_xy, 0.5 * c.stem.dbh_slice_m, 0.01, &rng);
      const TangentFit inner = CircleInsideStem(c.stem.centre_xy, 0.5 * c.stem.dbh_slice_m, share);
      c.fit.centre = inner.centre;
      c.fit.radius_m = inner.radius_m;
      c.fit.tried_views = c.fit.views = c.fit.two_sided_views = 20;
      SCOPED_TRACE(::testing::Message() << share << " of the stem at " << distance_m << " m");
      EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m, true), SilhouetteVerdict::kKeepCloud);
      EXPECT_EQ(JudgeSilhouetteFit(off, c.stem, c.fit, c.px_m, true), SilhouetteVerdict::kUse);
      // The same circle as a stem's own, its part widened by leaves around it: taken.
      Case leafy = c;
      leafy.stem.slice_xy = BarkArc(inner.centre, inner.radius_m, 0.01, &rng);
      std::uniform_real_distribution<double> across(-0.5 * c.stem.dbh_slice_m,
                                                    0.5 * c.stem.dbh_slice_m);
      const size_t bark_points = leafy.stem.slice_xy.size();
      for (size_t i = 0; i < bark_points; ++i) {
        leafy.stem.slice_xy.push_back(c.stem.centre_xy + Eigen::Vector2d(across(rng), across(rng)));
      }
      EXPECT_EQ(JudgeSilhouetteFit({}, leafy.stem, leafy.fit, leafy.px_m, true),
                SilhouetteVerdict::kUse);
    }
  }
}

// A sapling's leaves widen its cloud part, and hide its silhouettes in many views: where the
// bark lines up on the narrower fit, both sides in a quarter of the views outrank the cloud;
// without it, half of them must. Swept over the two-sided share, cloud part plain or smeared.
TEST(JudgeSilhouetteFit, ANarrowerFitWhoseBarkLinesUpNeedsFewerTwoSidedViews) {
  const MeasureOptions o;
  for (const bool smeared : {false, true}) {
    for (const int two_sided : {3, 5, 9, 10, 17, 18, 30}) {
      Case c;
      c.stem.depth_smeared = smeared;
      c.fit.radius_m = 0.07;  // under half the cloud's width, over narrow_min_share of it
      c.fit.tried_views = c.fit.views = 36;
      c.fit.two_sided_views = two_sided;
      for (const bool bark : {false, true}) {
        const double share = bark ? o.narrower_on_bark_two_sided_share : 0.5;
        const bool used = two_sided >= share * 36;
        const SilhouetteVerdict want =
            used ? SilhouetteVerdict::kUse : SilhouetteVerdict::kKeepCloud;
        EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, c.px_m, bark), want)
            << two_sided << " of 36 two-sided, bark " << (bark ? "lines up" : "does not")
            << (smeared ? ", smeared" : "");
      }
    }
  }
}

// A sapling 4-6 cm thick whose leaves or smeared points make a part 10-16 cm wide, its outline
// seen on both sides in a few views (leaves cover it in the rest): the fit places it at its own
// width, under sapling_outline_max_dbh_cm, where the bark does not line up on it; a circle as
// narrow inside a stem lies on the stem's bark, and a fit at a stem's width is judged as before.
// Swept over the part's width, the fit's, the two-sided views, the scatter and the bark.
TEST(JudgeSilhouetteFit, AThinTwoSidedOutlineInsideAWiderPartIsASapling) {
  const MeasureOptions o;
  for (const double part_cm : {10.0, 12.0, 16.0}) {
    for (const double fit_cm : {4.0, 5.0, 6.5, 7.5}) {
      for (const int two_sided : {2, 3, 5, 10}) {
        for (const double rms_px : {0.2, 1.0, 2.0}) {
          for (const bool bark : {false, true}) {
            for (const bool smeared : {false, true}) {
              Case c;
              c.stem.dbh_slice_m = 0.01 * part_cm;
              c.stem.depth_smeared = smeared;
              c.fit.radius_m = 0.005 * fit_cm;
              c.fit.tried_views = c.fit.views = 22;
              c.fit.two_sided_views = two_sided;
              c.fit.rms_m = rms_px * c.px_m;
              const bool within = fit_cm > 100 * o.tangent.narrow_min_share * c.stem.dbh_slice_m;
              const bool sapling = fit_cm < o.sapling_outline_max_dbh_cm && within &&
                                   two_sided >= 3 && rms_px < o.tight_fit_rms_px;
              const SilhouetteVerdict verdict = JudgeSilhouetteFit(o, c.stem, c.fit, c.px_m, bark);
              SCOPED_TRACE(::testing::Message()
                           << "part " << part_cm << " cm, fit " << fit_cm << " cm, two-sided in "
                           << two_sided << " of 22, " << rms_px << " px, bark " << bark
                           << (smeared ? ", smeared" : ""));
              MeasureOptions off = o;
              off.sapling_outline_max_dbh_cm = 0;
              if (sapling) {
                EXPECT_EQ(verdict, SilhouetteVerdict::kUse);
              } else {
                EXPECT_EQ(verdict, JudgeSilhouetteFit(off, c.stem, c.fit, c.px_m, bark));
              }
              const double narrower_share = bark ? o.narrower_on_bark_two_sided_share : 0.5;
              if (sapling && !smeared && two_sided < narrower_share * 22 &&
                  (part_cm - fit_cm) > 0.35 * part_cm + 2.0) {
                // Before: the part's width stood (a thin fit in few views outranks nothing).
                EXPECT_NE(JudgeSilhouetteFit(off, c.stem, c.fit, c.px_m, bark),
                          SilhouetteVerdict::kUse);
              }
            }
          }
        }
      }
    }
  }
  MeasureOptions o2;
  o2.sapling_outline_max_dbh_cm = -1;
  EXPECT_EQ(CheckMessage(o2), "the widest sapling's outline must lie in [0, 30] cm");
}

// A stem 12-20 cm thick whose cloud part took in a sapling's crown or a shrub beside it, three
// to six times its width: its own fit, both sides in nearly every view on one circle to about a
// pixel and its bark lining up, stands however narrow a share of the part it is; short of that
// (fewer two-sided views, a loose fit, bark that does not line up), the part's width stands as
// before; and a circle as narrow inside a stem of the part's width, whose own circle's bark lines
// up, is not taken. Swept over the stem's width and distance, the part's width, the views and the
// bark.
TEST(JudgeSilhouetteFit, AStemWholeInNearlyEveryViewStandsInAPartManyTimesItsWidth) {
  const MeasureOptions o;
  MeasureOptions off = o;
  off.whole_in_wide_part_two_sided_share = 0;
  for (const double distance_m : {2.5, 5.0}) {
    for (const double stem_cm : {12.0, 16.0, 20.0}) {
      for (const double times : {3.0, 4.5, 6.0}) {
        for (const int two_sided : {10, 13, 14, 15}) {
          for (const bool bark : {false, true}) {
            for (const double rms_px : {0.5, 2.0}) {
              Case c;
              c.stem.centre_xy = {distance_m, 0.0};
              c.stem.dbh_slice_m = 0.01 * times * stem_cm;
              c.px_m = distance_m / 1400.0;
              c.fit.centre = c.stem.centre_xy + Eigen::Vector2d(0.0, 0.3 * c.stem.dbh_slice_m);
              c.fit.radius_m = 0.005 * stem_cm;
              c.fit.tried_views = c.fit.views = 15;
              c.fit.two_sided_views = two_sided;
              c.fit.rms_m = rms_px * c.px_m;
              SCOPED_TRACE(::testing::Message()
                           << stem_cm << " cm at " << distance_m << " m in a part " << times
                           << " times as wide, two-sided in " << two_sided << " of 15, " << rms_px
                           << " px, bark " << bark);
              const bool whole = two_sided >= 0.9 * 15 && bark && rms_px < o.tight_fit_rms_px;
              const SilhouetteVerdict before = JudgeSilhouetteFit(off, c.stem, c.fit, c.px_m, bark);
              EXPECT_NE(before, SilhouetteVerdict::kUse);
              EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, c.px_m, bark),
                        whole ? SilhouetteVerdict::kUse : before);
            }
          }
        }
      }
      // A circle a quarter as wide inside a stem of the part's width, hugging one outline: the
      // stem's points past it lie nearer than its face and do not give it away, the bark of the
      // part's own circle does.
      std::mt19937 rng(5);
      Case inside;
      inside.stem.centre_xy = {distance_m, 0.0};
      inside.stem.dbh_slice_m = 0.04 * stem_cm;
      inside.px_m = distance_m / 1400.0;
      const double part_radius_m = 0.5 * inside.stem.dbh_slice_m;
      inside.stem.slice_xy = BarkArc(inside.stem.centre_xy, part_radius_m, 0.005, &rng);
      const TangentFit inner = CircleInsideStem(inside.stem.centre_xy, part_radius_m, 0.25);
      inside.fit.centre = inner.centre;
      inside.fit.radius_m = inner.radius_m;
      inside.fit.tried_views = inside.fit.views = inside.fit.two_sided_views = 15;
      inside.fit.rms_m = 0.5 * inside.px_m;
      int asked = 0;
      const auto part_is_bark = [&] { return ++asked > 0; };
      EXPECT_NE(JudgeSilhouetteFit(o, inside.stem, inside.fit, inside.px_m, true, part_is_bark),
                SilhouetteVerdict::kUse)
          << stem_cm << " cm at " << distance_m << " m";
      EXPECT_EQ(asked, 1);
      // Asked only of a fit that would stand for want of it: not of one at the part's width.
      inside.fit.radius_m = part_radius_m;
      inside.fit.centre = inside.stem.centre_xy;
      EXPECT_EQ(JudgeSilhouetteFit(o, inside.stem, inside.fit, inside.px_m, true, part_is_bark),
                SilhouetteVerdict::kUse);
      EXPECT_EQ(asked, 1);
    }
  }
  MeasureOptions bad;
  bad.whole_in_wide_part_two_sided_share = 1.5;
  EXPECT_EQ(CheckMessage(bad),
            "the share of views a fit in a wide part shows both sides in must lie in [0, 1]");
}

TEST(JudgeSilhouetteFit, RequiringSilhouettesDropsWhatNoneConfirms) {
  Case c;
  c.fit.ok = false;
  MeasureOptions o;
  o.require_silhouette = true;
  EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, c.px_m), SilhouetteVerdict::kDrop);
  c.fit.ok = true;  // a confirmed stem stays, required or not
  EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
}

TEST(JudgeSilhouetteFit, AWeaklySupportedPartNeedsBothSidesInSeveralViews) {
  Case c;
  c.stem.weak_support = true;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.fit.two_sided_views = 2;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kDrop);
}

TEST(JudgeSilhouetteFit, WiderTwoSidedSilhouettesOutrankTheCloud) {
  Case c;
  c.fit.radius_m = 0.25;  // the cloud saw part of a half-hidden stem
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.fit.rms_m = 0.02;  // the same width from sides that disagree by several pixels: not trusted
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
}

// A stem 1.9 m out, its section 1.5 cm out of round: its outline, a third wider than its
// smeared part, both sides in 9 of 12 views, misses one circle by 2.7 mm, 2.3 px at 1080p. Judged
// in pixels alone that is loose, and the part's width stood; judged to the millimetres a stem is
// round to, the outline places it. Far stems are judged in pixels.
TEST(JudgeSilhouetteFit, ANearStemsOutlineIsJudgedToTheMillimetresAStemIsRoundTo) {
  const MeasureOptions o;
  const double fx_px = 1620;
  Case c;
  c.stem.centre_xy = {0.4, -1.87};
  c.stem.dbh_slice_m = 0.189;
  c.stem.depth_smeared = true;
  c.fit.centre = c.stem.centre_xy;
  c.fit.radius_m = 0.125;
  c.fit.rms_m = 0.0027;
  c.fit.tried_views = c.fit.views = 12;
  c.fit.two_sided_views = 9;
  const double distance_m = c.stem.centre_xy.norm();
  EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, JudgedPixelM(o, distance_m, fx_px)),
            SilhouetteVerdict::kUse);
  EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, distance_m / fx_px),
            SilhouetteVerdict::kKeepCloud);
  // Twice as loose is loose at any distance.
  c.fit.rms_m = 0.0054;
  EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, JudgedPixelM(o, distance_m, fx_px)),
            SilhouetteVerdict::kKeepCloud);
  for (const double far_m : {5.0, 8.0, 12.0}) {
    EXPECT_DOUBLE_EQ(JudgedPixelM(o, far_m, fx_px), far_m / fx_px);
  }
  MeasureOptions pixels_alone = o;
  pixels_alone.min_judged_px_m = 0;
  EXPECT_DOUBLE_EQ(JudgedPixelM(pixels_alone, distance_m, fx_px), distance_m / fx_px);
}

// A near part with little surface at breast height stands only on silhouettes that agree to
// about a judged pixel: right near fits miss one circle by 2.4 mm (median) to 3.2 mm (90 %), and
// a fit at the 90th percentile, both sides in half its views, is such a fit; twice as loose is
// not, whatever the distance.
TEST(JudgeSilhouetteFit, AWeakNearPartStandsOnAFitAsRoundAsRightNearFitsAre) {
  const MeasureOptions o;
  const double fx_px = 1620;
  for (const Eigen::Vector2d& centre :
       {Eigen::Vector2d(1.2, -1.5), Eigen::Vector2d(-2.1, 0.4), Eigen::Vector2d(0.3, 2.6)}) {
    Case c;
    c.stem.centre_xy = centre;
    c.stem.dbh_slice_m = 0.25;
    c.stem.weak_support = true;
    c.fit.centre = centre;
    c.fit.radius_m = 0.13;
    c.fit.rms_m = 0.0031;
    c.fit.tried_views = c.fit.views = 12;
    c.fit.two_sided_views = 6;
    const double px_m = JudgedPixelM(o, centre.norm(), fx_px);
    EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, px_m), SilhouetteVerdict::kUse) << centre;
    c.fit.rms_m = 0.0062;
    EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, px_m), SilhouetteVerdict::kDrop) << centre;
  }
}

TEST(JudgeSilhouetteFit, AOneSidedFitCannotWidenTheCloud) {
  Case c;
  c.fit.two_sided_views = 2;
  c.fit.radius_m = 0.2;      // a third wider than the points, from one side
  c.fit.rms_m = 2 * c.px_m;  // with rays two pixels apart: unchecked
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
  c.stem.depth_smeared = true;  // a stem all the same: kept with the cloud's width, not dropped
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
  c.fit.radius_m = 0.145;  // narrower (the cloud's part of a stem can be smeared wider): used
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.fit.radius_m = 0.2;  // both sides in three views, agreeing: the wider fit is checked and used
  c.fit.two_sided_views = 3;
  c.fit.rms_m = 0.002;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
}

TEST(JudgeSilhouetteFit, ASmearedStemsFitMustStayWithinHalfToTwiceItsWidth) {
  Case c;
  c.stem.depth_smeared = true;
  c.fit.radius_m = 0.24;  // 1.6 times the smeared width: rough, used
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.fit.rms_m = 2 * c.px_m;  // but not from silhouettes that disagree by two pixels
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
  // Unless they keep near the points' width: 5 % wider, as a part not smeared may (else the
  // points' width stands, or a core of the part a third as wide, and the stem reads far thin).
  c.fit.radius_m = 0.157;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.stem.depth_smeared = false;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.stem.depth_smeared = true;
  c.fit.radius_m = 0.12;  // narrower than the points: the smeared width is no check on it
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.fit.rms_m = 0.002;
  c.fit.radius_m = 0.36;  // 2.4 times: a neighbour's edge; the silhouettes still confirm a stem
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
  c.fit.radius_m = 0.03;  // a fifth of it: one side of the stem and a furrow
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
  c.fit.ok = false;  // no silhouettes at all: a smeared part is not a stem
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kDrop);
}

TEST(JudgeSilhouetteFit, AOneSidedFitTangentToOneCircleWidensAStemTheCloudSawInPart) {
  Case c;
  c.fit.two_sided_views = 0;  // a nearer stem hides the other side in every view
  c.fit.radius_m = 0.2;       // a third wider than the points, its rays within half a pixel
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.stem.dbh_slice_m = 0.10;  // a part the cloud saw as a pole: one side cannot widen it
  c.fit.radius_m = 0.08;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kKeepCloud);
}

// The widest tangent start supposes 2.2 times the cloud's width; a fit that grew a little
// beyond it is still that stem, one far wider found something else.
TEST(JudgeSilhouetteFit, WiderSilhouettesUpToALittleBeyondTheWidestStart) {
  Case c;
  c.stem.depth_smeared = false;
  c.stem.weak_support = true;  // only silhouettes can keep it
  c.fit.radius_m = 2.6 * 0.15;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kUse);
  c.fit.radius_m = 2.9 * 0.15;
  EXPECT_EQ(JudgeSilhouetteFit({}, c.stem, c.fit, c.px_m), SilhouetteVerdict::kDrop);
  MeasureOptions o;
  o.tangent.wide_start_scales = {1.6};  // a narrower widest start narrows the bound
  c.fit.radius_m = 2.6 * 0.15;
  EXPECT_EQ(JudgeSilhouetteFit(o, c.stem, c.fit, c.px_m), SilhouetteVerdict::kDrop);
}

// Two stems 0.7 m apart, 6 m away, and a fit that took in both and the gap between them: its bark
// lines up at no distance, and the fit fails. A fit on one of them keeps its place and gets its
// distance from the bark.
TEST(CheckFitOnBark, AFitAcrossTwoStemsFails) {
  const Eigen::Vector3d a(6.0, 0.0, 0.1), b(6.0, 0.9, 0.1);
  const RenderedStem scene = RenderStems({a, b}, true, false, Texture::kIrregular);
  const TangentViews views{&scene.camera, &scene.keyframes, &scene.gray};
  TangentFit across;
  across.ok = true;
  across.centre = {6.0, 0.45};
  across.radius_m = 0.55;
  const BarkDepthOptions o;
  const TangentOptions t;
  TangentFit fit = across;
  const BarkDepth no_bark = CheckFitOnBark(o, t, views, 1.37, &fit);
  EXPECT_FALSE(fit.ok);
  EXPECT_GE(no_bark.pairs, o.min_pairs);
  EXPECT_LT(no_bark.peak_ncc, o.min_surface_ncc);
  fit = across;
  fit.centre = a.head<2>();
  fit.radius_m = a.z();
  const BarkDepth bark = CheckFitOnBark(o, t, views, 1.37, &fit);
  EXPECT_TRUE(fit.ok);
  ASSERT_TRUE(bark.ok);
  EXPECT_GT(bark.peak_ncc, o.min_peak_ncc);
  EXPECT_NEAR(bark.shift_m, 0.0, 0.01);
}

}  // namespace
}  // namespace stemmap::stems
