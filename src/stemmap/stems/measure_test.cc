#include "stemmap/stems/measure.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "stemmap/core/check_message.h"
#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"
#include "stemmap/stems/bark_depth.h"
#include "stemmap/stems/test_scene.h"

namespace stemmap::stems {
namespace {

TEST(MeasureOptions, AOneSidedBoundBelowTheCloudIsRejected) {
  MeasureOptions o;
  EXPECT_NO_THROW(o.Check());
  o.one_sided_max_over_cloud = 0.9;  // would replace fits narrower than the cloud too
  EXPECT_THROW(o.Check(), InputError);
  o = MeasureOptions();
  o.one_sided_min_cloud_radius_m = -0.01;
  EXPECT_THROW(o.Check(), InputError);
  o = MeasureOptions();
  o.min_core_share = 1.5;
  EXPECT_THROW(o.Check(), InputError);
  o = MeasureOptions();
  o.narrow_fit_share = -0.1;
  EXPECT_THROW(o.Check(), InputError);
}

TEST(MeasureOptions, TheTightAndLooseFitSettingsAreChecked) {
  MeasureOptions o;
  o.tight_fit_rms_px = 0;
  EXPECT_EQ(CheckMessage(o),
            "the rms of a tight fit must be positive and no more than that of a loose one");
  o.tight_fit_rms_px = o.loose_fit_rms_px + 0.5;
  EXPECT_EQ(CheckMessage(o),
            "the rms of a tight fit must be positive and no more than that of a loose one");
  o = MeasureOptions();
  o.min_judged_px_m = -0.001;
  EXPECT_EQ(CheckMessage(o), "the least a pixel counts as at a stem must lie in [0, 0.02] m");
  o = MeasureOptions();
  o.loose_wider_max_over_cloud = 0.95;
  EXPECT_EQ(CheckMessage(o),
            "the width over the cloud's a loose wider fit may reach must be at least 1");
  o = MeasureOptions();
  o.narrower_max_bark_past_outline = -0.1;
  EXPECT_EQ(CheckMessage(o),
            "the share of bark past a narrower fit's outline must not be negative");
  o.narrower_max_bark_past_outline = 0;  // off
  EXPECT_NO_THROW(o.Check());
}

TEST(MeasureOptions, TheLargerCloudsSettingsAreChecked) {
  MeasureOptions o;
  o.larger_cloud_part_gap_m = -0.1;
  EXPECT_EQ(CheckMessage(o),
            "the gap within which a larger cloud's part joins a stem must not be negative");
  o = MeasureOptions();
  o.larger_cloud_only_max_rms_px = -1;
  EXPECT_EQ(CheckMessage(o),
            "the rms a larger cloud's stem's silhouettes may keep must not be negative");
  o = MeasureOptions();
  o.fit_on_cloud_max_pass_through = 1.0;
  EXPECT_EQ(CheckMessage(o),
            "the share of rays that may pass a fit on the cloud must lie in [0, 1)");
  o = MeasureOptions();
  o.wide_fit_scale = 0.9;
  EXPECT_EQ(CheckMessage(o),
            "the width over the cloud's that needs the bark to line up must be at least 1");
  o = MeasureOptions();
  o.weak_on_bark_max_rms_px = -1;
  EXPECT_EQ(CheckMessage(o), "the rms of a weak part's outline on its bark must not be negative");
  o = MeasureOptions();
  o.leafy_edge_scatter_m = -0.01;
  EXPECT_EQ(CheckMessage(o), "a jagged silhouette's scatter about its line must not be negative");
  o = MeasureOptions();
  o.sides_past_nearer_min_views = -1;
  EXPECT_EQ(CheckMessage(o),
            "the views a stem behind a nearer one shows its sides in must not be negative");
  o = MeasureOptions();
  o.one_side_past_nearer_min_views = -1;
  EXPECT_EQ(CheckMessage(o),
            "the views a stem behind a nearer one shows its one side in must not be negative");
  o = MeasureOptions();
  o.hidden_side_min_gain = 0.5;
  EXPECT_EQ(CheckMessage(o),
            "the gain a hidden side's widest width must reach must be 0 or at least 1");
  o = MeasureOptions();
  o.hidden_side_min_seen_share = 1.2;
  EXPECT_EQ(CheckMessage(o),
            "the share of views a side toward a nearer stem must be seen in must lie in [0, 1]");
  o = MeasureOptions();
  o.hidden_side_stand_min_stems = 0;
  EXPECT_EQ(CheckMessage(o), "the stand's stems a hidden side's width needs must be at least 1");
  o = MeasureOptions();
  o.leafy_edge_share = 1.5;
  EXPECT_EQ(CheckMessage(o),
            "the share of jagged silhouettes that makes a fit leaves must lie in [0, 1]");
  o = MeasureOptions();
  o.wide_fit_min_bark_ncc = 1.5;
  EXPECT_EQ(CheckMessage(o), "the bark correlation a wide fit needs must lie in [-1, 1]");
  o = MeasureOptions();
  o.ground.cell_m = 0;
  EXPECT_EQ(CheckMessage(o), "the ground cell must lie in [0.1, 5] m");
  o = MeasureOptions();
  o.ground.windows_m = {2.0, 1.0};
  EXPECT_EQ(CheckMessage(o), "the ground filter's windows must be positive and growing");
}

TEST(MeasureOptions, TheSilhouettesSettingsAreChecked) {
  MeasureOptions o;
  o.narrower_on_bark_two_sided_share = 0.6;
  EXPECT_EQ(CheckMessage(o),
            "the two-sided share of a narrower fit whose bark lines up must lie in [0, 0.5]");
  o = MeasureOptions();
  o.outline_over_bark_two_sided_share = 1.5;
  EXPECT_EQ(CheckMessage(o),
            "the two-sided share of an outline that outweighs its bark must lie in [0, 1]");
  o = MeasureOptions();
  o.outline_over_bark_rms_px = -1;
  EXPECT_EQ(CheckMessage(o), "the rms of an outline that outweighs its bark must not be negative");
  o = MeasureOptions();
  o.outline_over_bark_cloud_share = -0.1;
  EXPECT_EQ(CheckMessage(o),
            "the cloud's share within which an outline outweighs its bark must not be negative");
  o = MeasureOptions();
  o.outline_over_bark_smear_m = -0.01;
  EXPECT_EQ(CheckMessage(o),
            "the cloud's smear an outline that outweighs its bark may be narrower by must not be "
            "negative");
  o = MeasureOptions();
  o.tangent.max_move_m = -0.1;
  EXPECT_EQ(CheckMessage(o),
            "the tangent fit's sideways reach and move, occluder gap and refits must not be "
            "negative");
  o = MeasureOptions();
  o.tangent.on_bark_max_rms_px = -1;
  EXPECT_EQ(CheckMessage(o), "the rms of a fit the bark lines up on must not be negative");
  o = MeasureOptions();
  o.tangent.rim_min_share = 1.2;
  EXPECT_EQ(CheckMessage(o),
            "the share of a wider fit a fit inside it must reach must lie in [0, 1]");
  o = MeasureOptions();
  o.tangent.tighter_rms_share = -0.1;
  EXPECT_EQ(CheckMessage(o), "the rms share of a tighter fit must lie in [0, 1]");
  o = MeasureOptions();
  o.tangent.min_views_each_side = -1;
  EXPECT_EQ(CheckMessage(o), "the views each side needs must not be negative");
  o = MeasureOptions();
  o.tangent.face_sigma_m = -0.01;
  EXPECT_EQ(CheckMessage(o),
            "the sigma of a stem's face's range must not be negative, its starts' growth above 1");
  o = MeasureOptions();
  o.tangent.face_start_growth = 1.0;
  EXPECT_EQ(CheckMessage(o),
            "the sigma of a stem's face's range must not be negative, its starts' growth above 1");
  o = MeasureOptions();
  o.tangent.narrow_start_scales = {1.5};
  EXPECT_EQ(CheckMessage(o), "the narrow starts' scales must lie in (0, 1)");
  o = MeasureOptions();
  o.tangent.wide_start_scales = {0.8};
  EXPECT_EQ(CheckMessage(o), "the wide starts' scales must exceed 1");
  o = MeasureOptions();
  o.tangent.min_rays = 2;
  EXPECT_EQ(CheckMessage(o), "the tangent fit needs a positive robust scale and prior, and 3 rays");
  o = MeasureOptions();
  o.tangent.blur_sigma_px = -1;
  EXPECT_EQ(CheckMessage(o), "the silhouettes' blur must not be negative");
  o = MeasureOptions();
  o.tangent.settle_min_change_share = -0.01;
  EXPECT_EQ(CheckMessage(o), "the change that leaves a fit unsettled must not be negative");
  o = MeasureOptions();
  o.tangent.max_bands_each_side = 0;
  EXPECT_EQ(CheckMessage(o),
            "the silhouettes' bands need at least one row, and one band on each side, within 1 m "
            "of breast height");
}

// A rendered scene and the cloud its keyframes' stereo would give: points on the part of each
// stem's bark a keyframe sees (not hidden by a nearer stem) between 0.8 and 2.2 m, each with the
// keyframe's centre as its ray origin, and flat ground at z = 0.
struct Scene {
  RenderedStem rendered;
  std::vector<cv::Mat> bgr;
  std::vector<dense::CloudPoint> cloud;
};

// Whether the segment from `from` to `to` (plot frame, horizontal) passes through one of the
// stems other than `self`.
bool Hidden(const std::vector<Eigen::Vector3d>& stems, size_t self, const Eigen::Vector2d& from,
            const Eigen::Vector2d& to) {
  for (size_t i = 0; i < stems.size(); ++i) {
    if (i == self) continue;
    const Eigen::Vector2d c = stems[i].head<2>(), d = to - from;
    const double t = std::clamp((c - from).dot(d) / d.squaredNorm(), 0.0, 1.0);
    if ((from + t * d - c).norm() < stems[i].z()) return true;
  }
  return false;
}

// Whether the segment from `from` to `to` passes through a leaf of one of the clumps.
bool BehindLeaves(const std::vector<LeafClump>& clumps, const Eigen::Vector3d& from,
                  const Eigen::Vector3d& to) {
  const double length = (to - from).norm();
  return std::ranges::any_of(clumps, [&](const LeafClump& c) {
    const double t = HitLeafClump(c, from, (to - from) / length);
    return t >= 0 && t < length - 0.01;
  });
}

// Stems (x, y, radius) and the leaf clumps (saplings' crowns) among them. `seen_half_arc_rad`:
// for the first stems, how far each side of the middle of the face a keyframe sees its stereo
// gives points (1.3 rad where not given; less: the cloud saw a sliver of it; negative: none, its
// points all smeared elsewhere). `smear`: circles the cloud has points on, as on a stem's face,
// though nothing stands there (stereo's smear of a farther stem toward the camera): in the cloud,
// hiding the points behind them, and not in the pictures. `texture`: the bark's. `cloud_wider_m`:
// the cloud's points of each stem lie on a circle this much wider in radius than the stem and
// scatter along their rays by twice that (standard deviation), as stereo's smear spreads a thin
// far stem's points past its outline and in depth.
Scene MakeScene(const std::vector<Eigen::Vector3d>& rendered_stems,
                const std::vector<LeafClump>& clumps = {},
                const std::vector<double>& seen_half_arc_rad = {},
                const std::vector<Eigen::Vector3d>& smear = {},
                Texture texture = Texture::kIrregular, double cloud_wider_m = 0.0) {
  Scene s;
  s.rendered = RenderStems(rendered_stems, /*textured_background=*/true, /*sunlit=*/false, texture,
                           PinholeCamera::FromHfov(960, 540, 67.0), clumps);
  std::vector<Eigen::Vector3d> stems = rendered_stems;
  stems.insert(stems.end(), smear.begin(), smear.end());
  for (const cv::Mat& g : s.rendered.gray) {
    s.bgr.emplace_back();
    cv::cvtColor(g, s.bgr.back(), cv::COLOR_GRAY2BGR);
  }
  Rng rng(3);
  for (int i = 0; i < 40000; ++i) {
    const Eigen::Vector3f p(rng.Uniform(-3, 13), rng.Uniform(-8, 8), rng.Normal(0, 0.01));
    s.cloud.push_back({p, Eigen::Vector3f(0, 0, 1.3f), cv::Vec3b(60, 70, 80), 0});
  }
  for (size_t k = 0; k < s.rendered.keyframes.size(); ++k) {
    const Eigen::Vector3d eye = s.rendered.keyframes[k].world_from_cam.translation;
    for (size_t i = 0; i < stems.size(); ++i) {
      const Eigen::Vector2d c = stems[i].head<2>();
      const double r = stems[i].z() + (i < rendered_stems.size() ? cloud_wider_m : 0.0);
      const double toward = std::atan2(eye.y() - c.y(), eye.x() - c.x());
      const double half_arc = i < seen_half_arc_rad.size() ? seen_half_arc_rad[i] : 1.3;
      if (half_arc < 0) continue;
      for (int j = 0; j < 120; ++j) {
        const double a = toward + rng.Uniform(-half_arc, half_arc);  // the side facing the camera
        const Eigen::Vector2d xy = c + r * Eigen::Vector2d(std::cos(a), std::sin(a));
        if (Hidden(stems, i, eye.head<2>(), xy)) continue;
        Eigen::Vector3d p(xy.x() + rng.Normal(0, 0.005), xy.y() + rng.Normal(0, 0.005),
                          rng.Uniform(0.8, 2.2));
        if (cloud_wider_m > 0) p += rng.Normal(0, 2 * cloud_wider_m) * (p - eye).normalized();
        if (BehindLeaves(clumps, eye, p)) continue;
        s.cloud.push_back(
            {p.cast<float>(), eye.cast<float>(), cv::Vec3b(50, 60, 70), static_cast<int>(k)});
      }
    }
    // The leaves each keyframe sees.
    for (const LeafClump& c : clumps) {
      for (int j = 0; j < 400; ++j) {
        const Eigen::Vector3d target =
            c.centre + c.radii_m.cwiseProduct(Eigen::Vector3d(
                           rng.Uniform(-1, 1), rng.Uniform(-1, 1), rng.Uniform(-1, 1)));
        const Eigen::Vector3d dir = (target - eye).normalized();
        const double t = HitLeafClump(c, eye, dir);
        if (t < 0) continue;
        const Eigen::Vector3d p = eye + t * dir;
        if (Hidden(stems, stems.size(), eye.head<2>(), p.head<2>())) continue;
        const Eigen::Vector3d noisy =
            p + Eigen::Vector3d(rng.Normal(0, 0.005), rng.Normal(0, 0.005), 0);
        s.cloud.push_back(
            {noisy.cast<float>(), eye.cast<float>(), cv::Vec3b(30, 60, 30), static_cast<int>(k)});
      }
    }
  }
  return s;
}

MeasureResult Measure(const Scene& s, const MeasureOptions& o = MeasureOptions()) {
  MeasureInput in;
  in.cloud = &s.cloud;
  in.camera = &s.rendered.camera;
  in.keyframes = &s.rendered.keyframes;
  in.bgr = &s.bgr;
  in.gray_full = s.rendered.gray;
  return MeasureTrees(o, std::move(in));
}

// Each true stem (x, y, radius) is listed once, within 3 cm and 1 cm of DBH.
void ExpectListed(const std::vector<Eigen::Vector3d>& truth, const MeasureResult& r) {
  ASSERT_EQ(r.trees.size(), truth.size());
  for (const Eigen::Vector3d& t : truth) {
    const auto it = std::ranges::min_element(
        r.trees, {}, [&](const Stem& s) { return (s.centre_xy - t.head<2>()).norm(); });
    SCOPED_TRACE(::testing::Message() << "stem at " << t.transpose());
    EXPECT_LT((it->centre_xy - t.head<2>()).norm(), 0.03);
    EXPECT_NEAR(it->dbh_m, 2 * t.z(), 0.01);
  }
  for (size_t i = 1; i < r.trees.size(); ++i) {
    EXPECT_LE(r.trees[i - 1].centre_xy.norm(), r.trees[i].centre_xy.norm()) << "nearest first";
  }
}

TEST(MeasureTrees, ListsEachStemOfAPlotWithItsWidth) {
  const std::vector<Eigen::Vector3d> truth = {
      {5.0, 0.6, 0.15}, {7.5, -1.8, 0.22}, {4.0, -1.2, 0.08}};
  const MeasureResult r = Measure(MakeScene(truth));
  ExpectListed(truth, r);
  // Each in plain view: both silhouettes in most views on one circle, and its bark lines up.
  for (const Stem& s : r.trees) {
    EXPECT_GT(2 * s.evidence.two_sided_views, s.evidence.tried_views);
    EXPECT_LT(s.evidence.rms_px, 1.0);
    EXPECT_GE(s.evidence.bark_pairs, BarkDepthOptions().min_pairs);
    EXPECT_GT(s.evidence.bark_ncc, BarkDepthOptions().min_peak_ncc);
  }
  EXPECT_EQ(r.summary["dbh_method"], "tangent");
  EXPECT_GT(r.summary["ground_cells"].get<int>(), 0);
}

// A stem partly behind a nearer one, over a range of offsets across the line of sight, from
// half hidden from the plot centre to just clear of it. (Straight behind, 0.05-0.15 m off the
// nearer stem's bearing: AThickStemStraightBehindANearerOneIsListed. Right on it:
// AStemRightOnANearerStemsBearingIsHeldOnItsFace.)
TEST(MeasureTrees, AStemBehindANearerOneIsListedAtEveryOffset) {
  for (double offset_m : {0.25, 0.4, 0.6}) {
    SCOPED_TRACE(::testing::Message() << "offset " << offset_m << " m");
    const std::vector<Eigen::Vector3d> truth = {{4.0, 0.0, 0.12}, {8.0, offset_m, 0.2}};
    ExpectListed(truth, Measure(MakeScene(truth)));
  }
}

// A thick stem straight behind a thick nearer one, 3-4.5 m farther and 5-15 cm off its
// bearing: where the far stem is in the picture the nearer one hides all of it but one side, from
// one end of the arm the left, from the other the right, too few rays to fit a circle to; its
// cloud saw the sliver between. Listed, flagged (occluded, one-sided or no silhouette), within 5
// cm, its DBH within a tenth and within 2 SD. (Before sides seen one at a time kept it on its
// cloud, four of these six were missed.)
TEST(MeasureTrees, AThickStemStraightBehindANearerOneIsListed) {
  struct Pair {
    Eigen::Vector3d nearer, farther;  // x, y, radius (m)
  };
  const std::vector<Pair> pairs = {
      {{3.04, 0.0, 0.229}, {7.0, 0.08, 0.2375}}, {{3.04, 0.0, 0.229}, {7.0, 0.18, 0.2375}},
      {{4.2, 0.0, 0.19}, {8.5, 0.10, 0.19}},     {{4.2, 0.0, 0.19}, {8.5, 0.15, 0.19}},
      {{2.5, 0.0, 0.15}, {6.0, 0.08, 0.12}},     {{3.5, 0.0, 0.2}, {6.5, 0.05, 0.15}}};
  for (const Pair& p : pairs) {
    SCOPED_TRACE(::testing::Message() << "farther stem " << p.farther.transpose());
    const MeasureResult r = Measure(MakeScene({p.nearer, p.farther}));
    ASSERT_EQ(r.trees.size(), 2u);
    const Stem& far = r.trees[1];
    EXPECT_LT((far.centre_xy - p.farther.head<2>()).norm(), 0.05);
    EXPECT_NEAR(far.dbh_m, 2 * p.farther.z(), 0.1 * 2 * p.farther.z());
    EXPECT_LE(std::abs(far.dbh_m - 2 * p.farther.z()), 2 * far.dbh_sd_m);
    // Its width rests on less than two sides, and says so.
    EXPECT_TRUE(far.flags.Has(StemFlag::kOccluded) || far.flags.Has(StemFlag::kOneSided) ||
                far.flags.Has(StemFlag::kNoSilhouette));
  }
}

// A thick stem right on the bearing of a nearer, thinner one (3.5-4 m behind it), whose cloud
// saw its face whole or only a sliver of it (10 degrees each side of the middle): the nearer stem
// hides its left side from one end of the arm and its right side from the other. Before its fit
// was held on its face, the fit from one side per view slid 0.6 m along the line of sight, or the
// stem was missed, or its sliver's width listed. Now listed within 7 cm and 1.5 cm of DBH.
TEST(MeasureTrees, AStemRightOnANearerStemsBearingIsHeldOnItsFace) {
  struct Pair {
    Eigen::Vector3d nearer, farther;  // x, y, radius (m)
  };
  const std::vector<Pair> pairs = {{{4.0, 0.0, 0.12}, {8.0, 0.0, 0.2}},
                                   {{3.0, 0.0, 0.2}, {6.5, 0.0, 0.18}},
                                   {{5.0, 0.0, 0.15}, {9.0, 0.0, 0.22}}};
  for (const double seen_half_arc_rad : {1.3, 0.175}) {
    for (const Pair& p : pairs) {
      SCOPED_TRACE(::testing::Message() << "farther stem " << p.farther.transpose()
                                        << ", its cloud's half arc " << seen_half_arc_rad);
      const MeasureResult r =
          Measure(MakeScene({p.nearer, p.farther}, {}, {1.3, seen_half_arc_rad}));
      ASSERT_EQ(r.trees.size(), 2u);
      const Stem& far = r.trees[1];
      EXPECT_LT((far.centre_xy - p.farther.head<2>()).norm(), 0.07);
      EXPECT_NEAR(far.dbh_m, 2 * p.farther.z(), 0.015);
      EXPECT_TRUE(far.flags.Has(StemFlag::kOccluded));
    }
  }
}

// A thick stem 4 m behind a nearer one and 1.2-2.8 degrees off its bearing, whose cloud saw only
// a sliver of its face (17 degrees each side of the middle): the nearer stem hides the side
// toward it in (nearly) every view where the stem is in the picture, and where the width seen
// puts that side, most views show none: the stem goes on behind. Listed, flagged
// width_from_stand, its DBH between the width seen and the widest that stays hidden, within 2
// SD. Two pairs: a 44-cm stem 9 m out behind a 36.6-cm one 5 m out (before, listed at the
// sliver's width, 12.7 cm, SD 3.9-6.4 cm; at 1.6 and 2.4 degrees on a fit whose near side came
// from 3 views, 16.5 and 19.8 cm, 2.4-3.3 SD off), and a 36-cm stem 8 m out behind a 38-cm one 4
// m out (its near side found in 3 of the 10 views that would show it; before, 15.9 and 26.9 cm,
// not flagged). With no stand beside a pair, the middle of the two bounds stands in for the
// stand's mean: within a quarter of the truth where the bounds are 44-83 cm (the first pair),
// not where they are 16-102 cm.
TEST(MeasureTrees, AStemWhoseCloudSawASliverBesideANearerOneIsNotReadAsTheSliver) {
  struct Pair {
    Eigen::Vector3d nearer;  // x, y, radius (m)
    double distance_m, radius_m;
    std::vector<double> bearings_deg;
    double max_relative_error;
  };
  const std::vector<Pair> pairs = {{{5.0, 0.0, 0.183}, 9.0, 0.22, {1.2, 1.6, 2.4, 2.8}, 0.25},
                                   {{4.0, 0.0, 0.19}, 8.0, 0.18, {2.0, 2.5}, 1.0}};
  for (const Pair& p : pairs) {
    for (const double deg : p.bearings_deg) {
      const double a = deg * M_PI / 180;
      const Eigen::Vector3d far(p.distance_m * std::cos(a), p.distance_m * std::sin(a), p.radius_m);
      SCOPED_TRACE(::testing::Message() << "farther stem " << far.transpose());
      const MeasureResult r = Measure(MakeScene({p.nearer, far}, {}, {1.3, 0.3}));
      ASSERT_EQ(r.trees.size(), 2u);
      const Stem& s = r.trees[1];
      EXPECT_LT((s.centre_xy - far.head<2>()).norm(), 0.3);
      EXPECT_TRUE(s.flags.Has(StemFlag::kWidthFromStand));
      EXPECT_LT(s.dbh_seen_m, s.dbh_m);
      EXPECT_LT(s.dbh_m, s.dbh_hidden_max_m);
      EXPECT_LE(s.dbh_seen_m, 2 * far.z());
      EXPECT_GE(s.dbh_hidden_max_m, 2 * far.z());
      EXPECT_LE(std::abs(s.dbh_m - 2 * far.z()), 2 * s.dbh_sd_m);
      EXPECT_LT(std::abs(s.dbh_m - 2 * far.z()), p.max_relative_error * 2 * far.z());
    }
  }
}

// A thick stem behind a thinner, nearer one, its centre at the edge of the nearer one's outline
// seen from the plot centre (1.3-1.46 degrees off its bearing, the outline reaching 1.4): from
// every point of the arm where the stem is in the picture the nearer one hides the side toward
// it, and the other side shows in every view. Its cloud saw 0.5-1.3 rad each side of its middle.
// Listed, within 5 cm, its DBH within 12 % and 2 SD, flagged occluded and one-sided. (Before the
// fit held on its face stood on one side, two of these four were missed and a third placed 19
// cm too near.)
TEST(MeasureTrees, AThickStemWhoseOneSideANearerStemHidesIsListedOnTheOther) {
  struct Case {
    Eigen::Vector3d nearer;  // x, y, radius (m)
    double distance_m, radius_m, bearing_deg, seen_half_arc_rad;
  };
  const std::vector<Case> cases = {{{5.8, 0.0, 0.1415}, 9.67, 0.2075, 1.42, 1.3},
                                   {{5.8, 0.0, 0.1415}, 9.67, 0.2075, 1.46, 1.3},
                                   {{5.8, 0.0, 0.1415}, 9.67, 0.2075, 1.46, 0.8},
                                   {{6.0, 0.0, 0.15}, 9.5, 0.23, 1.3, 0.5}};
  for (const Case& c : cases) {
    const double a = c.bearing_deg * M_PI / 180;
    const Eigen::Vector3d far(c.distance_m * std::cos(a), c.distance_m * std::sin(a), c.radius_m);
    SCOPED_TRACE(::testing::Message() << "farther stem " << far.transpose()
                                      << ", its cloud's half arc " << c.seen_half_arc_rad);
    const MeasureResult r = Measure(MakeScene({c.nearer, far}, {}, {1.3, c.seen_half_arc_rad}));
    ASSERT_EQ(r.trees.size(), 2u);
    const Stem& s = r.trees[1];
    EXPECT_LT((s.centre_xy - far.head<2>()).norm(), 0.05);
    EXPECT_NEAR(s.dbh_m, 2 * far.z(), 0.12 * 2 * far.z());
    EXPECT_LE(std::abs(s.dbh_m - 2 * far.z()), 2 * s.dbh_sd_m);
    EXPECT_TRUE(s.flags.Has(StemFlag::kOccluded));
    EXPECT_TRUE(s.flags.Has(StemFlag::kOneSided));
  }
}

// A thin stem just beside a nearer, thicker one on its bearing, 0.9-1 m behind it: hidden from
// the plot centre in part, it shows whole from one end of the arm and one side at a time from the
// other. Swept over thin stems 1.1-2.4 degrees off the thick one's bearing (the thick one's
// outline reaching 1.2-1.6 degrees) in three stands. Listed once, within 10 cm (its distance
// rests on few two-sided views) and 1 cm of DBH, the error within its 2 SD.
TEST(MeasureTrees, AThinStemJustBesideANearerOneOnItsBearingIsListed) {
  struct Pair {
    Eigen::Vector3d nearer;  // x, y, radius (m)
    double distance_m, radius_m;
    std::vector<double> bearings_deg;
  };
  const std::vector<Pair> pairs = {{{4.2, 0.0, 0.11}, 5.1, 0.05, {1.6, 2.0, 2.4}},
                                   {{4.6, 0.0, 0.1315}, 5.5, 0.0505, {2.0}},
                                   {{3.9, 0.0, 0.08}, 4.8, 0.0505, {1.1}}};
  for (const Pair& p : pairs) {
    for (const double deg : p.bearings_deg) {
      const double a = deg * M_PI / 180;
      const Eigen::Vector3d thin(p.distance_m * std::cos(a), p.distance_m * std::sin(a),
                                 p.radius_m);
      SCOPED_TRACE(::testing::Message() << "thin stem at " << thin.transpose());
      const MeasureResult r = Measure(MakeScene({p.nearer, thin}));
      ASSERT_EQ(r.trees.size(), 2u);
      for (const Eigen::Vector3d& t : {p.nearer, thin}) {
        const auto it = std::ranges::min_element(
            r.trees, {}, [&](const Stem& s) { return (s.centre_xy - t.head<2>()).norm(); });
        EXPECT_LT((it->centre_xy - t.head<2>()).norm(), 0.1) << t.transpose();
        EXPECT_NEAR(it->dbh_m, 2 * t.z(), 0.01) << t.transpose();
        EXPECT_LE(std::abs(it->dbh_m - 2 * t.z()), 2 * it->dbh_sd_m) << t.transpose();
      }
    }
  }
}

// A stem the arm passes close by (its bark 0.6-1.1 m from the camera): seen large, in few
// views, its section reaching far across the picture.
TEST(MeasureTrees, AStemCloseToTheArmIsListed) {
  for (const double gap_m : {0.6, 1.1}) {
    for (const double r_m : {0.08, 0.15}) {
      SCOPED_TRACE(::testing::Message() << "bark " << gap_m << " m from the arm, radius " << r_m);
      const std::vector<Eigen::Vector3d> truth = {{1.0 + gap_m + r_m, 0.2, r_m}};
      ExpectListed(truth, Measure(MakeScene(truth)));
    }
  }
}

// A sapling (3 cm) whose leafy crown reaches down to breast height, 6.5 m out, with a stem
// beside it: the crown's cloud and its outline, two-sided in most views, make a candidate as a
// trunk's would, but its silhouettes are jagged from band to band, and it is no stem. Swept over
// crowns 0.6-0.9 m across centred at 1.3-1.6 m (breast height in the crown's middle or lower
// part).
TEST(MeasureTrees, ASaplingsLeafyCrownAtBreastHeightIsNoStem) {
  const Eigen::Vector3d stem(5.0, -1.2, 0.12), sapling(6.5, 0.3, 0.015);
  for (const double centre_z_m : {1.3, 1.6}) {
    for (const double radius_m : {0.3, 0.45}) {
      SCOPED_TRACE(::testing::Message() << "crown at " << centre_z_m << " m, radius " << radius_m);
      const LeafClump crown{
          {sapling.x(), sapling.y(), centre_z_m}, {radius_m, radius_m, 0.7 * radius_m}, 0.35};
      ExpectListed({stem}, Measure(MakeScene({stem, sapling}, {crown})));
    }
  }
}

// A stem 1.5 m behind a sapling's leafy crown, across a range of offsets from the crown's
// bearing: the crown, no stem, still hides what its outline covers, so the stem's silhouettes
// are not looked for on its leaves. (Straight behind it, offset 0, the stem is listed but read
// 1.5 cm thin and 13 cm near: docs/benchmarks.md, limits.)
TEST(MeasureTrees, AStemBehindASaplingsCrownIsListed) {
  const Eigen::Vector3d sapling(6.5, 0.3, 0.015);
  const LeafClump crown{{sapling.x(), sapling.y(), 1.4}, {0.35, 0.35, 0.3}, 0.35};
  for (const double offset_m : {0.6, 0.3, -0.3}) {
    SCOPED_TRACE(::testing::Message() << "offset " << offset_m << " m");
    const Eigen::Vector3d stem(8.0, sapling.y() + offset_m, 0.15);
    ExpectListed({stem}, Measure(MakeScene({stem, sapling}, {crown})));
  }
}

// A stem with a sapling's leafy crown against one side at breast height (the sapling 0.45-0.6 m
// beside it, the crown 0.6 m across, in front of it or behind it as seen from the plot centre):
// the leaves' jagged edges replace that side's silhouette in many views, the other side stays
// straight, and the stem is listed with its width.
TEST(MeasureTrees, AStemWithACrownAgainstOneSideIsListed) {
  const Eigen::Vector3d stem(5.5, 0.0, 0.13);
  for (const Eigen::Vector2d& beside : {Eigen::Vector2d(5.3, 0.45), Eigen::Vector2d(5.8, -0.5)}) {
    SCOPED_TRACE(::testing::Message() << "sapling at " << beside.transpose());
    const Eigen::Vector3d sapling(beside.x(), beside.y(), 0.015);
    const LeafClump crown{{beside.x(), beside.y(), 1.4}, {0.3, 0.3, 0.25}, 0.35};
    ExpectListed({stem}, Measure(MakeScene({stem, sapling}, {crown})));
  }
}

// A stem whose points stereo smeared toward the camera: the cloud has none on its bark, and a
// part 1.2-2 m in front of it on its bearing, as wide as the stem seen from there or a little
// narrower, where nothing stands. The part shows no silhouettes and comes to nothing; the stem,
// found where its silhouettes meet (SilhouetteVoteOptions), is listed with its width: the part
// does not hide its sides from its edge search (it did, MeasureOptions::unfitted_parts_hide, and
// the stem went unlisted).
TEST(MeasureTrees, AStemBehindSmearWhereNothingStandsIsListed) {
  const Eigen::Vector3d stem(8.0, 0.0, 0.14);
  for (const double ahead_m : {1.2, 2.0}) {
    for (const double width_share : {0.8, 1.0}) {
      SCOPED_TRACE(::testing::Message() << "smear " << ahead_m << " m ahead, " << width_share
                                        << " of the stem's apparent width");
      const double x = stem.x() - ahead_m;
      const Eigen::Vector3d smear(x, 0.0, width_share * stem.z() * x / stem.x());
      ExpectListed({stem}, Measure(MakeScene({stem}, {}, {-1.0}, {smear})));
    }
  }
}

// A thick stem 2.8-3.2 m out just behind a thin one 1.8-2 m out (under a metre from the arm),
// 1-2 degrees off its bearing, whose points stereo smeared elsewhere: from the arm the nearer stem
// hides its middle, and its sides show one at a time, each from its own end of the arm. The
// silhouettes' votes find it; listed on its silhouettes alone, flagged occluded, within 5 cm and
// a fifth of its DBH (its sides, seen past the nearer stem, bound it loosely), the error within
// 2 SD. (Before a fit agreeing with the votes' circle counted each side seen in views of its own,
// SilhouetteVoteOptions::agree_min_views_each_side, the third was missed.)
TEST(MeasureTrees, AThickStemJustBehindAThinOneNearTheArmIsListedOnItsVotes) {
  struct Pair {
    Eigen::Vector3d nearer;  // x, y, radius (m)
    double distance_m, radius_m, bearing_deg;
  };
  const std::vector<Pair> pairs = {{{1.85, 0.0, 0.073}, 3.0, 0.1765, -1.4},
                                   {{2.0, 0.0, 0.08}, 3.2, 0.16, 1.0},
                                   {{1.8, 0.0, 0.07}, 2.8, 0.18, 2.0}};
  for (const Pair& p : pairs) {
    const double a = p.bearing_deg * M_PI / 180;
    const Eigen::Vector3d far(p.distance_m * std::cos(a), p.distance_m * std::sin(a), p.radius_m);
    SCOPED_TRACE(::testing::Message() << "farther stem " << far.transpose());
    const MeasureResult r = Measure(MakeScene({p.nearer, far}, {}, {1.3, -1.0}));
    ASSERT_EQ(r.trees.size(), 2u);
    const Stem& s = r.trees[1];
    EXPECT_LT((s.centre_xy - far.head<2>()).norm(), 0.05);
    EXPECT_NEAR(s.dbh_m, 2 * far.z(), 0.2 * 2 * far.z());
    EXPECT_LE(std::abs(s.dbh_m - 2 * far.z()), 2 * s.dbh_sd_m);
    EXPECT_TRUE(s.flags.Has(StemFlag::kOccluded));
    EXPECT_TRUE(s.flags.Has(StemFlag::kSilhouetteOnly));
  }
}

// A thin stem several metres out in plain view, both outlines in every view, whose bark
// correlates nowhere between views (too fine for the pixels, or shadows moving across it), and
// whose points stereo spread 2.5-3.5 cm past its outline on either side and 5-7 cm in depth: its
// outline stands on the cloud's place against its bark. Listed once, DBH within 1 cm, within 6 cm
// (its distance from the outlines' parallax alone: the bark does not line up to correct it). Swept
// over its width, distance and the cloud's spread. (Before the smear allowance,
// outline_over_bark_smear_m, a stem whose cloud was a fifth or more wider than its outline was not
// listed.)
TEST(MeasureTrees, AThinFarStemWhoseBarkCorrelatesNowhereIsListedOnItsOutline) {
  for (const double radius_m : {0.06, 0.075}) {
    for (const double distance_m : {6.0, 7.5}) {
      for (const double wider_m : {0.025, 0.035}) {
        SCOPED_TRACE(::testing::Message() << "radius " << radius_m << " m at " << distance_m
                                          << " m, cloud wider by " << wider_m << " m");
        const Eigen::Vector2d centre(distance_m, 0.4);
        const MeasureResult r = Measure(MakeScene({{centre.x(), centre.y(), radius_m}}, {}, {}, {},
                                                  Texture::kNoisyBark, wider_m));
        ASSERT_EQ(r.trees.size(), 1u);
        EXPECT_LT((r.trees[0].centre_xy - centre).norm(), 0.06);
        EXPECT_NEAR(r.trees[0].dbh_m, 2 * radius_m, 0.01);
      }
    }
  }
}

TEST(MeasureTrees, NoStemsInAnEmptyPlotAndMissingInputsAreRefused) {
  const Scene s = MakeScene({});
  EXPECT_TRUE(Measure(s).trees.empty());
  MeasureInput none;
  EXPECT_THROW(MeasureTrees(MeasureOptions(), std::move(none)), ProcessingError);
}

}  // namespace
}  // namespace stemmap::stems
