#include "stemmap/stems/silhouette_votes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"
#include "stemmap/stems/test_scene.h"

namespace stemmap::stems {
namespace {

// Rays tangent to the circle (centre, radius) on both sides, from arm positions (unit circle)
// at angles phi0..phi1 (rad), each with the range its parallax gives within `span_m`.
std::vector<SilhouetteRay> TangentRays(const Eigen::Vector2d& centre, double radius, double phi0,
                                       double phi1, int n, double span_m) {
  std::vector<SilhouetteRay> rays;
  for (int k = 0; k < n; ++k) {
    const double phi = phi0 + (phi1 - phi0) * k / (n - 1);
    const Eigen::Vector2d o(std::cos(phi), std::sin(phi));
    const Eigen::Vector2d d = centre - o;
    const double dist = d.norm(), bearing = std::atan2(d.y(), d.x());
    const double half = std::asin(radius / dist);
    for (const int side : {-1, 1}) {
      SilhouetteRay r;
      r.origin_xy = o;
      // The silhouette at bearing + half has the stem on its right (lower azimuth).
      r.azimuth_rad = bearing + side * half;
      r.near_side = -side;
      r.distance_m = dist * std::cos(half);
      r.min_distance_m = r.distance_m - span_m;
      r.max_distance_m = r.distance_m + span_m;
      rays.push_back(r);
    }
  }
  return rays;
}

TEST(SilhouetteVoteOptions, EveryFieldIsChecked) {
  EXPECT_NO_THROW(SilhouetteVoteOptions{}.Check());
  auto throws = [](auto change) {
    SilhouetteVoteOptions o;
    change(o);
    EXPECT_THROW(o.Check(), InputError);
  };
  throws([](SilhouetteVoteOptions& o) { o.max_candidates = -1; });
  throws([](SilhouetteVoteOptions& o) { o.min_gap_to_listed_m = -0.1; });
  throws([](SilhouetteVoteOptions& o) { o.cell_m = 0; });
  throws([](SilhouetteVoteOptions& o) { o.max_radius_m = 0.01; });
  throws([](SilhouetteVoteOptions& o) { o.radius_step_m = 0; });
  throws([](SilhouetteVoteOptions& o) { o.min_range_m = -1; });
  throws([](SilhouetteVoteOptions& o) { o.strip_rows = 1; });
  throws([](SilhouetteVoteOptions& o) { o.strip_half_height_m = 0; });
  throws([](SilhouetteVoteOptions& o) { o.min_edge_step = 0; });
  throws([](SilhouetteVoteOptions& o) { o.min_edge_straightness = 1.5; });
  throws([](SilhouetteVoteOptions& o) { o.neighbour_baseline_m = 0; });
  throws([](SilhouetteVoteOptions& o) { o.short_baseline_m = -0.01; });
  throws([](SilhouetteVoteOptions& o) { o.short_baseline_m = o.neighbour_baseline_m; });
  throws([](SilhouetteVoteOptions& o) { o.min_cell_votes = 0; });
  throws([](SilhouetteVoteOptions& o) { o.min_cell_votes = o.min_votes + 1; });
  throws([](SilhouetteVoteOptions& o) { o.side_patch_px = 2; });
  throws([](SilhouetteVoteOptions& o) { o.max_parallax_px = 0.5; });
  throws([](SilhouetteVoteOptions& o) { o.min_side_ncc = 2; });
  throws([](SilhouetteVoteOptions& o) { o.parallax_sd_px = 0; });
  throws([](SilhouetteVoteOptions& o) { o.min_vote_span_m = -1; });
  throws([](SilhouetteVoteOptions& o) { o.min_votes = 0; });
  throws([](SilhouetteVoteOptions& o) { o.min_separation_m = -1; });
  throws([](SilhouetteVoteOptions& o) { o.min_votes_each_side = -1; });
  throws([](SilhouetteVoteOptions& o) { o.agree_radius_share = -0.1; });
  throws([](SilhouetteVoteOptions& o) { o.agree_min_two_sided_views = -1; });
  throws([](SilhouetteVoteOptions& o) { o.agree_min_views_each_side = -1; });
}

TEST(FitAgreesWithVotes, RadiusWithinItsShareCentreWithinTheRadiusBothSidesInViews) {
  const SilhouetteVoteOptions o;
  const Eigen::Vector2d c(6, 1);
  EXPECT_TRUE(FitAgreesWithVotes(o, c, 0.1, c + Eigen::Vector2d(0.05, 0), 0.12, 3));
  EXPECT_FALSE(FitAgreesWithVotes(o, c, 0.1, c, 0.13, 3));  // wider by over a fifth and 5 mm
  EXPECT_FALSE(FitAgreesWithVotes(o, c, 0.1, c + Eigen::Vector2d(0.11, 0), 0.1, 3));
  EXPECT_FALSE(FitAgreesWithVotes(o, c, 0.1, c, 0.1, 2));  // both sides in too few views
  // Past a nearer stem, each side in views of its own will do.
  EXPECT_TRUE(FitAgreesWithVotes(o, c, 0.1, c, 0.1, 0, 4));
  EXPECT_FALSE(FitAgreesWithVotes(o, c, 0.1, c, 0.1, 1, 3));
  EXPECT_FALSE(FitAgreesWithVotes(o, c, 0.1, c, 0.13, 0, 9));
  // A thin stem's centre may move a cell.
  EXPECT_TRUE(FitAgreesWithVotes(o, c, 0.03, c + Eigen::Vector2d(0, 0.045), 0.03, 3));
  SilhouetteVoteOptions off = o;
  off.agree_min_two_sided_views = 0;
  EXPECT_FALSE(FitAgreesWithVotes(off, c, 0.1, c, 0.1, 30));
}

TEST(VoteStemCentres, TangentRaysMeetAtTheStemsCentreAndRadius) {
  const SilhouetteVoteOptions o;
  // Stems of every width and distance the plot holds, seen over the arm's usual 60-degree arc.
  for (const double dist : {2.5, 5.0, 9.0}) {
    for (const double radius : {0.05, 0.12, 0.3}) {
      const Eigen::Vector2d centre = dist * Eigen::Vector2d(std::cos(0.4), std::sin(0.4));
      const std::vector<VoteCandidate> found =
          VoteStemCentres(o, TangentRays(centre, radius, -0.1, 0.9, 30, 0.3), 11.0);
      ASSERT_FALSE(found.empty()) << dist << " " << radius;
      EXPECT_LT((found[0].centre_xy - centre).norm(), 0.08) << dist << " " << radius;
      EXPECT_NEAR(found[0].radius_m, radius, 0.02) << dist << " " << radius;
      EXPECT_GE(found[0].votes, 50);
    }
  }
}

TEST(VoteStemCentres, ScatteredSilhouettesMeetNowhere) {
  SilhouetteVoteOptions o;
  // As many silhouettes as a plot gives in a keyframe's worth of arc, at random bearings and
  // ranges: no place gathers min_votes of them.
  Rng rng(5);
  std::vector<SilhouetteRay> rays;
  for (int k = 0; k < 2000; ++k) {
    SilhouetteRay r;
    const double phi = rng.Uniform(0, 2 * M_PI);
    r.origin_xy = {std::cos(phi), std::sin(phi)};
    r.azimuth_rad = phi + rng.Uniform(-0.5, 0.5);
    r.near_side = rng.Uniform(0, 1) < 0.5 ? -1 : 1;
    r.distance_m = rng.Uniform(1, 10);
    r.min_distance_m = r.distance_m - 0.3;
    r.max_distance_m = r.distance_m + 0.3;
    rays.push_back(r);
  }
  EXPECT_TRUE(VoteStemCentres(o, rays, 11.0).empty());
  // Where they meet a stem's, the stem stands out.
  const Eigen::Vector2d centre(-4, 3);
  const std::vector<SilhouetteRay> stem = TangentRays(centre, 0.1, 2.2, 3.0, 12, 0.3);
  rays.insert(rays.end(), stem.begin(), stem.end());
  const std::vector<VoteCandidate> found = VoteStemCentres(o, rays, 11.0);
  ASSERT_FALSE(found.empty());
  EXPECT_LT((found[0].centre_xy - centre).norm(), 0.1);
}

TEST(VoteStemCentres, OneSideOfAStemBehindANearerOneFromEachEndOfTheArm) {
  const SilhouetteVoteOptions o;
  // The nearer stem hides the left side from one end of the arc, the right from the other.
  const Eigen::Vector2d centre(7, 0.2);
  std::vector<SilhouetteRay> rays;
  for (const SilhouetteRay& r : TangentRays(centre, 0.15, -0.6, -0.2, 10, 0.4)) {
    if (r.near_side == 1) rays.push_back(r);
  }
  for (const SilhouetteRay& r : TangentRays(centre, 0.15, 0.2, 0.6, 10, 0.4)) {
    if (r.near_side == -1) rays.push_back(r);
  }
  const std::vector<VoteCandidate> found = VoteStemCentres(o, rays, 11.0);
  ASSERT_FALSE(found.empty());
  EXPECT_LT((found[0].centre_xy - centre).norm(), 0.15);
  EXPECT_NEAR(found[0].radius_m, 0.15, 0.03);
}

TEST(VoteStemCentres, NothingNearTheArmOrBeyondTheSearch) {
  SilhouetteVoteOptions o;
  for (const Eigen::Vector2d& centre : {Eigen::Vector2d(1.1, 0), Eigen::Vector2d(11.5, 0)}) {
    const std::vector<VoteCandidate> found =
        VoteStemCentres(o, TangentRays(centre, 0.1, -0.3, 0.3, 20, 0.3), 11.0);
    for (const VoteCandidate& c : found) {
      EXPECT_GE(c.centre_xy.norm(), o.min_range_m);
      EXPECT_LE(c.centre_xy.norm(), 11.0);
    }
  }
}

// The silhouettes the keyframes of a rendered scene give: each tangent to a stem, its nearer
// side toward it.
TEST(FindSilhouetteRays, RenderedStemsGiveTheirTangentsAndTheirSide) {
  const SilhouetteVoteOptions o;
  const std::vector<Eigen::Vector3d> stems = {{5.0, 0.6, 0.15}, {3.0, -1.2, 0.08}};
  const RenderedStem scene = RenderStems(stems, true, false, Texture::kIrregular);
  const std::vector<SilhouetteRay> rays =
      FindSilhouetteRays(o, scene.camera, scene.keyframes, scene.gray);
  int tangent = 0, tangent_near_side = 0;
  for (const SilhouetteRay& r : rays) {
    const Eigen::Vector2d u(std::cos(r.azimuth_rad), std::sin(r.azimuth_rad));
    for (const Eigen::Vector3d& s : stems) {
      const Eigen::Vector2d q = s.head<2>() - r.origin_xy;
      const double across = u.x() * q.y() - u.y() * q.x();  // + left of the ray
      if (std::abs(std::abs(across) - s.z()) > 0.01 || q.dot(u) < 0) continue;
      ++tangent;
      const bool side_right = (across > 0) == (r.near_side > 0);
      const double along = q.dot(u);
      if (side_right && along >= r.min_distance_m && along <= r.max_distance_m) {
        ++tangent_near_side;
      }
    }
  }
  // Of the 34 views' 136 sides (fewer are in the picture), most give a silhouette.
  EXPECT_GE(tangent, 50);
  EXPECT_GE(tangent_near_side, 0.9 * tangent);
  // And they meet at both stems.
  const std::vector<VoteCandidate> found = VoteStemCentres(o, rays, 11.0);
  for (const Eigen::Vector3d& s : stems) {
    const bool met = std::ranges::any_of(found, [&](const VoteCandidate& c) {
      return (c.centre_xy - s.head<2>()).norm() < 0.15 && std::abs(c.radius_m - s.z()) < 0.03;
    });
    EXPECT_TRUE(met) << s.transpose();
  }
}

// A stem straight behind a nearer one, over a range of offsets across the line of sight that
// leave both of its sides in view from some arm positions: its sides seen past the nearer stem meet
// near it, within the reach of the silhouettes' fit (TangentOptions::max_move_m).
TEST(FindSilhouetteRays, AStemBehindANearerOneGathersVotesOfItsOwn) {
  const SilhouetteVoteOptions o;
  for (const double offset_m : {-0.08, 0.0, 0.08, 0.15}) {
    const std::vector<Eigen::Vector3d> stems = {{3.0, 0.3, 0.12}, {7.0, 0.7 + offset_m, 0.16}};
    const RenderedStem scene = RenderStems(stems, true, false, Texture::kIrregular);
    const std::vector<VoteCandidate> found =
        VoteStemCentres(o, FindSilhouetteRays(o, scene.camera, scene.keyframes, scene.gray), 11.0);
    const bool met = std::ranges::any_of(found, [&](const VoteCandidate& c) {
      return (c.centre_xy - stems[1].head<2>()).norm() < 0.5;
    });
    EXPECT_TRUE(met) << offset_m;
  }
}

// A stem 8 m out, a degree round from a nearer one 3 m out, that shows whole, clear of it, only
// between that stem and the picture's border, over six keyframes (12 degrees of the arm, under
// twice the neighbours' baseline): at the ends of that stretch the neighbours at
// neighbour_baseline_m see the nearer stem or the border where its sides were, the keyframes at
// short_baseline_m see them. Over a range of bearings, its silhouettes meet near it.
TEST(FindSilhouetteRays, AStemShownBrieflyBesideANearerOneGathersVotes) {
  const SilhouetteVoteOptions o;
  for (const double bearing_deg : {18.0, 22.0, 26.0}) {
    const double bearing = bearing_deg * M_PI / 180;
    const Eigen::Vector2d far = 8.0 * Eigen::Vector2d(std::cos(bearing), std::sin(bearing));
    const Eigen::Vector2d near =
        3.0 * Eigen::Vector2d(std::cos(bearing + 0.02), std::sin(bearing + 0.02));
    const RenderedStem scene =
        RenderStems({{near.x(), near.y(), 0.15}, {far.x(), far.y(), 0.15}}, true, false,
                    Texture::kIrregular, PinholeCamera::FromHfov(960, 540, 67.0));
    const std::vector<VoteCandidate> found =
        VoteStemCentres(o, FindSilhouetteRays(o, scene.camera, scene.keyframes, scene.gray), 11.0);
    const bool met = std::ranges::any_of(found, [&](const VoteCandidate& c) {
      return (c.centre_xy - far).norm() < 0.5 && std::abs(c.radius_m - 0.15) < 0.03;
    });
    EXPECT_TRUE(met) << bearing_deg << " deg";
  }
}

// A stem behind a sapling's leaf clump at breast height, over a range of offsets where both of
// its sides show past the leaves from some arm positions: its silhouettes meet at it.
TEST(FindSilhouetteRays, AStemBehindALeafClumpGathersVotes) {
  const SilhouetteVoteOptions o;
  for (const double offset_m : {-0.5, 0.35, 0.5}) {
    const LeafClump clump{{3.5, 0.3 + offset_m, 1.3}, {0.35, 0.35, 0.6}, 0.5};
    const Eigen::Vector2d stem(7.0, 0.6);
    const RenderedStem scene =
        RenderStems({{stem.x(), stem.y(), 0.15}}, true, false, Texture::kIrregular,
                    PinholeCamera::FromHfov(640, 360, 67.0), {clump});
    const std::vector<VoteCandidate> found =
        VoteStemCentres(o, FindSilhouetteRays(o, scene.camera, scene.keyframes, scene.gray), 11.0);
    const bool met = std::ranges::any_of(found, [&](const VoteCandidate& c) {
      return (c.centre_xy - stem).norm() < 0.15 && std::abs(c.radius_m - 0.15) < 0.03;
    });
    EXPECT_TRUE(met) << offset_m;
  }
}

// A stem seen whole from a short stretch of the arm (five keyframes over 0.12 rad), each
// silhouette's bearing off by 2 mrad (15 mm at the stem) one way or the other: the rays cross at
// shallow angles and spread their votes over neighbouring cells, none of some stems' holding
// min_votes; refined from a cell with min_cell_votes, they meet near the stem, at its radius.
TEST(VoteStemCentres, FewViewsFromAShortArcMeetOnceRefined) {
  const SilhouetteVoteOptions o;
  for (const double bearing : {0.3, 0.7, 1.1}) {
    const Eigen::Vector2d centre = 8.0 * Eigen::Vector2d(std::cos(bearing), std::sin(bearing));
    std::vector<SilhouetteRay> rays =
        TangentRays(centre, 0.09, bearing - 0.16, bearing - 0.04, 5, 0.5);
    for (size_t i = 0; i < rays.size(); ++i) rays[i].azimuth_rad += (i % 3 == 0 ? 1 : -1) * 2e-3;
    const std::vector<VoteCandidate> found = VoteStemCentres(o, rays, 11.0);
    const bool met = std::ranges::any_of(found, [&](const VoteCandidate& c) {
      return (c.centre_xy - centre).norm() < 0.5 && std::abs(c.radius_m - 0.09) < 0.03;
    });
    EXPECT_TRUE(met) << bearing;
  }
}

TEST(VoteStemCentres, SilhouettesOfOneSideAloneAreNoStem) {
  const SilhouetteVoteOptions o;
  std::vector<SilhouetteRay> rays;
  for (const SilhouetteRay& r : TangentRays({6, 1}, 0.15, -0.2, 0.6, 30, 0.3)) {
    if (r.near_side == 1) rays.push_back(r);
  }
  EXPECT_TRUE(VoteStemCentres(o, rays, 11.0).empty());
}

}  // namespace
}  // namespace stemmap::stems
