#include "stemmap/stems/stems.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <string>

#include "stemmap/core/check_message.h"
#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"
#include "stemmap/stems/measure.h"

namespace stemmap::stems {
namespace {

constexpr int kGroundPoints = 60000, kTrunkPoints = 3000;

// Flat ground around the plot centre, seen from the axis.
std::vector<dense::CloudPoint> FlatGround(Rng* rng) {
  std::vector<dense::CloudPoint> cloud;
  for (int i = 0; i < kGroundPoints; ++i) {
    const Eigen::Vector3d p(rng->Uniform(-12, 12), rng->Uniform(-12, 12), rng->Normal(0, 0.01));
    cloud.push_back({p.cast<float>(), Eigen::Vector3f(0, 0, 1.3f), cv::Vec3b(80, 90, 100), 0});
  }
  return cloud;
}

// A point seen from a camera on the 1-m arm within 30° of its bearing.
void AddSeenFromArm(const Eigen::Vector3d& p, Rng* rng, std::vector<dense::CloudPoint>* cloud) {
  const double arm = std::atan2(p.y(), p.x()) + rng->Uniform(-0.5, 0.5);
  const Eigen::Vector3d origin(std::cos(arm), std::sin(arm), 1.3);
  cloud->push_back({p.cast<float>(), origin.cast<float>(), cv::Vec3b(80, 90, 100), 0});
}

// Stems in a synthetic cloud with the bearing split off: it would part these clouds already,
// where real smears defeat it.
StemsResult DetectWithoutBearingSplit(const std::vector<dense::CloudPoint>& cloud,
                                      bool split_parts_into_cores = true) {
  const GroundGrid ground(cloud, 13);
  StemOptions o;
  o.split_by_bearing = false;
  o.split_parts_into_cores = split_parts_into_cores;
  return DetectStems(o, cloud, ground);
}

// The stems the cloud shows on its own, without those on weak support that wait for silhouettes
// to confirm them. Each of those must lie in `where`, the clutter of the scene.
std::vector<Stem> StemsOnTheirPoints(const StemsResult& r,
                                     const std::function<bool(const Eigen::Vector2d&)>& where) {
  std::vector<Stem> out;
  for (const Stem& s : r.stems) {
    if (!s.weak_support) {
      out.push_back(s);
    } else {
      EXPECT_TRUE(where(s.centre_xy)) << s.centre_xy.transpose();
    }
  }
  return out;
}

Stem StemAt(double x, double y, double dbh_m) {
  Stem s;
  s.centre_xy = {x, y};
  s.dbh_m = dbh_m;
  return s;
}

TEST(AttachLargerCloudParts, AnOverlappingPartThatDiffersJoinsTheNearestStem) {
  // A 31.9-cm stem of which the cloud saw an 18.8-cm sliver, the larger cloud 30.8 cm.
  std::vector<Stem> found = {StemAt(4.99, -4.49, 0.188), StemAt(1.88, -1.90, 0.343),
                             StemAt(8.0, 0.0, 0.3)};
  const std::vector<Stem> more = {
      StemAt(4.98, -4.58, 0.308),  // differs: joins the sliver
      StemAt(1.88, -1.90, 0.344),  // the same stem as found: nothing to add
      StemAt(8.0, 0.9, 0.3),       // a stem of its own, 0.6 m clear of any: not attached
      StemAt(5.40, -4.49, 0.2)};   // overlaps the sliver too, but farther than the first
  EXPECT_EQ(AttachLargerCloudParts(more, 0.1, &found), 1);
  ASSERT_EQ(found[0].larger_cloud_part.size(), 1u);
  EXPECT_DOUBLE_EQ(found[0].larger_cloud_part[0].dbh_m, 0.308);
  EXPECT_TRUE(found[1].larger_cloud_part.empty());
  EXPECT_TRUE(found[2].larger_cloud_part.empty());
}

TEST(StemsAwayFrom, KeepsTheStemsClearOfEveryFoundOneNearestFirst) {
  // A thin stem behind a wider one, where the cloud has no part.
  const std::vector<Stem> found = {StemAt(-4.44, 1.24, 0.216), StemAt(8.0, 0.0, 0.3)};
  std::vector<Stem> more = {
      StemAt(-8.46, 2.29, 0.106),  // clear of both
      StemAt(8.0, 0.27, 0.2),      // its bark 2 cm from the found stem's: the same stem
      StemAt(2.0, 1.0, 0.15)};     // clear, and nearer the centre
  more[0].alternatives = {StemAt(-8.45, 2.29, 0.1)};
  const std::vector<Stem> away = StemsAwayFrom(more, 0.1, found);
  ASSERT_EQ(away.size(), 2u);
  EXPECT_DOUBLE_EQ(away[0].centre_xy.x(), 2.0);
  EXPECT_DOUBLE_EQ(away[1].centre_xy.x(), -8.46);
  EXPECT_TRUE(away[1].alternatives.empty());
}

TEST(Stems, CircleFromAnArc) {
  Rng rng(1);
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < 200; ++i) {  // the half a camera on the arm sees, with 2 mm noise
    const double a = rng.Uniform(-M_PI / 2, M_PI / 2);
    pts.emplace_back(5 + 0.2 * std::cos(a + M_PI) + rng.Normal(0, 0.002),
                     1 + 0.2 * std::sin(a + M_PI) + rng.Normal(0, 0.002));
  }
  Eigen::Vector2d c;
  double r = 0, rms = 0;
  ASSERT_TRUE(FitCircle(pts, &c, &r, &rms));
  EXPECT_NEAR(r, 0.2, 0.005);
  EXPECT_NEAR((c - Eigen::Vector2d(5, 1)).norm(), 0.0, 0.005);
  EXPECT_NEAR(rms, 0.002, 0.001);
  EXPECT_FALSE(FitCircle({{0, 0}, {1, 1}}, &c, &r, &rms));
}

// A synthetic cloud: flat ground and two trunks seen from the arm; one "trunk" is a ghost that
// rays pass through. Points of the first trunk come first after the ground.
std::vector<dense::CloudPoint> TwoTrunksAndAGhost() {
  Rng rng(2);
  std::vector<dense::CloudPoint> cloud;
  auto add = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& origin) {
    cloud.push_back({p.cast<float>(), origin.cast<float>(), cv::Vec3b(80, 90, 100), 0});
  };
  const Eigen::Vector3d cam(1, 0, 1.3);
  for (int i = 0; i < kGroundPoints; ++i) {
    add(Eigen::Vector3d(rng.Uniform(-12, 12), rng.Uniform(-12, 12), rng.Normal(0, 0.01)), cam);
  }
  const std::vector<std::pair<Eigen::Vector2d, double>> trunks = {{{5, 0}, 0.15}, {{0, -6}, 0.25}};
  for (const auto& [c, r] : trunks) {
    for (int i = 0; i < kTrunkPoints; ++i) {
      const double a = rng.Uniform(0, 2 * M_PI), z = rng.Uniform(0, 3);
      add(Eigen::Vector3d(c.x() + r * std::cos(a), c.y() + r * std::sin(a), z), cam);
    }
  }
  // Ghost at (0, 6): points there, but from the axis the same directions see far beyond it.
  for (int i = 0; i < 3000; ++i) {
    const double a = rng.Uniform(0, 2 * M_PI), z = rng.Uniform(0, 3);
    add(Eigen::Vector3d(0.2 * std::cos(a), 6 + 0.2 * std::sin(a), z), cam);
  }
  for (int i = 0; i < 2000; ++i) {  // a thin spread of far points, not a trunk
    add(Eigen::Vector3d(rng.Uniform(-0.15, 0.15), rng.Uniform(8.5, 10.5), rng.Uniform(1.2, 1.8)),
        Eigen::Vector3d(0, 0, 1.3));
  }
  return cloud;
}

TEST(StemOptions, CheckRejectsOutOfRangeValues) {
  for (auto set : std::vector<std::function<void(StemOptions*)>>{
           [](StemOptions* o) { o->lean_slice_min_points = 1; },
           [](StemOptions* o) { o->lean_slice_min_share = 1.5; },
           [](StemOptions* o) { o->lean_slice_min_share = -0.1; }}) {
    StemOptions o;
    set(&o);
    EXPECT_THROW(o.Check(), InputError);
  }
  StemOptions o;
  EXPECT_EQ(CheckMessage(o), "");
  o.free_space_veto = 0;
  EXPECT_EQ(CheckMessage(o), "free_space_veto must be in (0, 1]");
  o.free_space_veto = 1.2;
  EXPECT_EQ(CheckMessage(o), "free_space_veto must be in (0, 1]");
  o = StemOptions();
  o.mixed_part_lone_core_max_share = 1.5;
  EXPECT_EQ(CheckMessage(o), "mixed_part_lone_core_max_share must be in [0, 1]");
}

// The DBH method reads back by name from an options file, and a name it does not have is an
// error naming the choices, not the first method.
TEST(Stems, ReadsTheDbhMethodByNameAndRefusesAnother) {
  StemOptions o;
  o.dbh_method = DbhMethod::kSlice;
  const nlohmann::json j = o;
  EXPECT_EQ(j.at("dbh_method"), "slice");
  EXPECT_EQ(j.get<StemOptions>().dbh_method, DbhMethod::kSlice);
  nlohmann::json girth = j;
  girth["dbh_method"] = "girth";
  EXPECT_EQ(InputErrorMessage([&] { (void)girth.get<StemOptions>(); }),
            "DBH method 'girth' is not tangent, slice or circle");
  girth["dbh_method"] = 2;
  EXPECT_THROW((void)girth.get<StemOptions>(), InputError);
}

// Band points of a stem (c, r) seen from the arm within 30° of its bearing: rays to its face,
// a share of them (`stray_share`) placed far beyond it as a mismatched stereo pixel is, the rest
// off by 1 % depth noise along the ray.
std::vector<dense::CloudPoint> FaceSeenFromArm(const Eigen::Vector2d& c, double r,
                                               double stray_share, Rng* rng) {
  std::vector<dense::CloudPoint> band;
  const double bearing = std::atan2(c.y(), c.x());
  for (int i = 0; i < 4000; ++i) {
    const double arm = bearing + rng->Uniform(-0.5, 0.5);
    const Eigen::Vector2d o(std::cos(arm), std::sin(arm));
    const Eigen::Vector2d to_c = c - o;
    const double half_angle = std::asin(std::min(1.0, r / to_c.norm()));
    const double a = std::atan2(to_c.y(), to_c.x()) + rng->Uniform(-0.95, 0.95) * half_angle;
    const Eigen::Vector2d u(std::cos(a), std::sin(a));
    const double t = u.dot(to_c), miss2 = to_c.squaredNorm() - t * t;
    const double face = t - std::sqrt(std::max(0.0, r * r - miss2));
    const double depth = rng->Uniform(0, 1) < stray_share ? face + rng->Uniform(0.4, 2.0)
                                                          : face + rng->Normal(0, 0.01 * face);
    const Eigen::Vector2d e = o + depth * u;
    band.push_back({Eigen::Vector3f(e.x(), e.y(), 1.3f), Eigen::Vector3f(o.x(), o.y(), 1.3f),
                    cv::Vec3b(80, 90, 100), 0});
  }
  return band;
}

std::vector<const dense::CloudPoint*> Pointers(const std::vector<dense::CloudPoint>& cloud) {
  std::vector<const dense::CloudPoint*> out;
  for (const dense::CloudPoint& p : cloud) out.push_back(&p);
  return out;
}

// A stem near the tripod, seen on its front arc, a sixth of its rays astray: at its own circle
// its bark ends the rays (what MeasureOptions::fit_on_cloud_max_pass_through asks of a fit), but
// a part's circle set 8-10 cm behind the bark reads as free space and is vetoed. A clump the rays
// pass through three times as often as they end on it is free space at its own circle. Over
// stems 1.5-3 m out, 10-40 cm thick.
TEST(PassThroughRatio, ANearStemsBarkEndsTheRaysAtItsCircleNotBehindIt) {
  const StemOptions o;
  const double surface_max_pass_through = MeasureOptions().fit_on_cloud_max_pass_through;
  Rng rng(7);
  for (double range_m : {1.5, 2.0, 3.0}) {
    for (double dbh_m : {0.10, 0.20, 0.32, 0.40}) {
      const Eigen::Vector2d c = range_m * Eigen::Vector2d(0.6, 0.8);
      const double r = dbh_m / 2;
      const std::string where = std::to_string(range_m) + " m out, " + std::to_string(dbh_m) + " m";
      const std::vector<dense::CloudPoint> stem = FaceSeenFromArm(c, r, 1.0 / 6, &rng);
      int hits = 0;
      EXPECT_LE(PassThroughRatio(Pointers(stem), c, r, &hits), surface_max_pass_through) << where;
      EXPECT_GE(hits, o.min_points) << where;
      for (double back_m : {0.08, 0.1}) {
        EXPECT_GT(PassThroughRatio(Pointers(stem), c + back_m * c.normalized(), 0.9 * r),
                  o.free_space_veto)
            << where << ", set back " << back_m;
      }
      const std::vector<dense::CloudPoint> clump = FaceSeenFromArm(c, r, 0.75, &rng);
      EXPECT_GT(PassThroughRatio(Pointers(clump), c, r), o.free_space_veto) << "clump " << where;
    }
  }
}

// The far spread of TwoTrunksAndAGhost.
bool InTheFarSpread(const Eigen::Vector2d& xy) {
  return std::abs(xy.x()) < 0.3 && xy.y() > 8.4 && xy.y() < 10.6;
}

TEST(Stems, DetectsTrunksAndVetoesAGhost) {
  const std::vector<dense::CloudPoint> cloud = TwoTrunksAndAGhost();
  const GroundGrid ground(cloud, 13);
  EXPECT_NEAR(ground.Height(3, 3), 0.0, 0.05);
  StemOptions o;
  o.dbh_method = DbhMethod::kCircle;
  const StemsResult r = DetectStems(o, cloud, ground);
  // The thin spread of far points is too wide for a stem; its denser cores wait for silhouettes.
  const std::vector<Stem> stems = StemsOnTheirPoints(r, InTheFarSpread);
  ASSERT_EQ(stems.size(), 2u);
  EXPECT_GE(r.vetoed_free_space, 1);
  // The ghost is kept aside, measured, for a later look at its silhouettes.
  const auto ghost = std::ranges::find_if(
      r.vetoed, [](const Stem& v) { return (v.centre_xy - Eigen::Vector2d(0, 6)).norm() < 0.1; });
  ASSERT_NE(ghost, r.vetoed.end());
  EXPECT_GT(ghost->pass_through, o.free_space_veto);
  EXPECT_TRUE(ghost->weak_support);
  EXPECT_NEAR(ghost->dbh_m, 0.40, 0.02);
  EXPECT_NEAR((stems[0].centre_xy - Eigen::Vector2d(5, 0)).norm(), 0, 0.02);
  EXPECT_NEAR(stems[0].dbh_m, 0.30, 0.01);
  EXPECT_NEAR(stems[1].dbh_m, 0.50, 0.01);
}

// With a learned trunk mask, points it calls "not a trunk" build no stem.
TEST(Stems, TrunkMaskKeepsOtherSurfacesOut) {
  std::vector<dense::CloudPoint> cloud = TwoTrunksAndAGhost();
  for (size_t i = 0; i < cloud.size(); ++i) {
    const bool first_trunk = i >= kGroundPoints && i < kGroundPoints + kTrunkPoints;
    cloud[i].trunk = first_trunk ? 0 : 1;
  }
  const GroundGrid ground(cloud, 13);
  StemOptions o;
  o.dbh_method = DbhMethod::kCircle;
  const StemsResult r = DetectStems(o, cloud, ground);
  const std::vector<Stem> stems = StemsOnTheirPoints(r, InTheFarSpread);
  ASSERT_EQ(stems.size(), 1u);
  EXPECT_NEAR((stems[0].centre_xy - Eigen::Vector2d(0, -6)).norm(), 0, 0.02);
  EXPECT_GE(r.vetoed_free_space, 1);  // the ghost's points are "trunk", its rays still veto it
}

// Breast-height support: a far trunk with too few slice points for its distance is kept only as
// weak (for silhouettes to confirm), one with far fewer is dropped.
TEST(Stems, ThinlySeenFarTrunksAreWeakOrDropped) {
  Rng rng(5);
  std::vector<dense::CloudPoint> cloud;
  const Eigen::Vector3d origin(0, 0, 1.3);
  auto add = [&](const Eigen::Vector3d& p) {
    cloud.push_back({p.cast<float>(), origin.cast<float>(), cv::Vec3b(80, 90, 100), 0});
  };
  for (int i = 0; i < kGroundPoints; ++i) {
    add(Eigen::Vector3d(rng.Uniform(-12, 12), rng.Uniform(-12, 12), rng.Normal(0, 0.01)));
  }
  // Front faces at 9 m: ~120 and ~40 points within the ±5 cm slice.
  for (const auto& [bearing, n] : {std::pair{0.3, 3600}, std::pair{2.0, 1200}}) {
    const Eigen::Vector2d c = 9.0 * Eigen::Vector2d(std::cos(bearing), std::sin(bearing));
    for (int i = 0; i < n; ++i) {
      const double a = bearing + M_PI + rng.Uniform(-1.2, 1.2);
      add(Eigen::Vector3d(c.x() + 0.15 * std::cos(a), c.y() + 0.15 * std::sin(a),
                          rng.Uniform(0, 3)));
    }
  }
  const GroundGrid ground(cloud, 13);
  const StemsResult r = DetectStems(StemOptions(), cloud, ground, 500.0);
  ASSERT_EQ(r.stems.size(), 1u);
  EXPECT_TRUE(r.stems[0].weak_support);
  EXPECT_NEAR(std::atan2(r.stems[0].centre_xy.y(), r.stems[0].centre_xy.x()), 0.3, 0.02);
  EXPECT_GE(r.rejected_size, 1);
}

// A far trunk as stereo sees it: its front face smeared ±0.4 m along the line of sight. Its
// circle fit means nothing; the width across the line of sight still gives bearing and size.
TEST(Stems, SmearedFarTrunkIsKeptByItsWidthAcross) {
  Rng rng(4);
  std::vector<dense::CloudPoint> cloud;
  const Eigen::Vector3d origin(0, 0, 1.3);
  for (int i = 0; i < 60000; ++i) {
    const Eigen::Vector3d p(rng.Uniform(-12, 12), rng.Uniform(-12, 12), rng.Normal(0, 0.01));
    cloud.push_back({p.cast<float>(), origin.cast<float>(), cv::Vec3b(80, 90, 100), 0});
  }
  const double bearing = 0.6, range = 9.5, r = 0.17;
  const Eigen::Vector2d u(std::cos(bearing), std::sin(bearing)), across(-u.y(), u.x());
  for (int i = 0; i < 4000; ++i) {
    const double a = rng.Uniform(-1.3, 1.3);  // the face toward the centre
    const Eigen::Vector2d xy =
        (range + r - r * std::cos(a) + rng.Uniform(-0.4, 0.4)) * u + r * std::sin(a) * across;
    const Eigen::Vector3d p(xy.x(), xy.y(), rng.Uniform(0, 3));
    cloud.push_back({p.cast<float>(), origin.cast<float>(), cv::Vec3b(80, 90, 100), 0});
  }
  const GroundGrid ground(cloud, 13);
  const StemsResult res = DetectStems(StemOptions(), cloud, ground);
  ASSERT_EQ(res.stems.size(), 1u);
  const Stem& s = res.stems[0];
  EXPECT_TRUE(s.depth_smeared);
  EXPECT_NEAR(std::atan2(s.centre_xy.y(), s.centre_xy.x()), bearing, 0.005);
  EXPECT_NEAR(s.centre_xy.norm(), range + r, 0.3);
  EXPECT_NEAR(s.dbh_slice_m, 2 * r, 0.05);
  // Its DBH is as good as a depth pixel there (the width's ends), not the spread of no circle.
  const StemsResult coarse = DetectStems(StemOptions(), cloud, ground, 100.0);
  ASSERT_EQ(coarse.stems.size(), 1u);
  EXPECT_NEAR(coarse.stems[0].dbh_sd_m, coarse.stems[0].centre_xy.norm() / 100.0, 1e-9);
}

// A near trunk seen only up to 1.6 m (its top is out of view), with a few stray points joined to
// it higher up and off to one side: the strays must not read as a lean.
TEST(Stems, NearTrunkWithStrayPointsAboveIsVertical) {
  Rng rng(6);
  std::vector<dense::CloudPoint> cloud;
  const Eigen::Vector3d origin(0, 0, 1.3);
  auto add = [&](const Eigen::Vector3d& p) {
    cloud.push_back({p.cast<float>(), origin.cast<float>(), cv::Vec3b(80, 90, 100), 0});
  };
  for (int i = 0; i < 60000; ++i) {
    add(Eigen::Vector3d(rng.Uniform(-12, 12), rng.Uniform(-12, 12), rng.Normal(0, 0.01)));
  }
  const Eigen::Vector2d c(-1.1, -1.6);
  const double r = 0.15, bearing = std::atan2(c.y(), c.x());
  for (int i = 0; i < 20000; ++i) {
    const double a = bearing + M_PI + rng.Uniform(-1.2, 1.2);
    add(Eigen::Vector3d(c.x() + r * std::cos(a), c.y() + r * std::sin(a), rng.Uniform(0.9, 1.6)));
  }
  for (int i = 0; i < 800; ++i) {  // strays up to 0.6 m behind, 1.7-2.1 m up, touching the trunk
    const double d = rng.Uniform(0.0, 0.6), side = rng.Uniform(-0.03, 0.03);
    add(Eigen::Vector3d(c.x() - d * 0.55 + side * 0.83, c.y() - d * 0.83 - side * 0.55,
                        rng.Uniform(1.7, 2.1)));
  }
  const GroundGrid ground(cloud, 13);
  const StemsResult res = DetectStems(StemOptions(), cloud, ground, 500.0);
  ASSERT_EQ(res.stems.size(), 1u);
  EXPECT_LT((res.stems[0].centre_xy - c).norm(), 0.05);
  EXPECT_LT(res.stems[0].lean_deg, 5.0);
}

// A trunk the arm passes close by: each height of it is seen from other arm positions (the
// frame's bottom edge cuts the lower bark from the nearest ones), so the arcs of its surface that
// the band's thirds hold face different ways, and their centroids stand apart by most of its
// radius. The trunk is upright: its lean comes from the thirds' circles, not their centroids.
TEST(Stems, ANearTrunkSeenOnOtherArcsAtEachHeightIsUpright) {
  for (const double turn : {0.5, 0.9}) {
    SCOPED_TRACE(::testing::Message() << "arcs " << turn << " rad apart");
    Rng rng(8);
    std::vector<dense::CloudPoint> cloud = FlatGround(&rng);
    const Eigen::Vector2d c(1.37, 1.07);
    const double r = 0.155, facing = std::atan2(-c.y(), -c.x());
    for (int i = 0; i < 20000; ++i) {
      const double z = rng.Uniform(1.0, 1.75);
      // The arc seen turns with height: from `turn` / 2 one way at the bottom to the other way.
      const double mid = facing + turn * ((z - 1.0) / 0.75 - 0.5);
      const double a = mid + rng.Uniform(-0.9, 0.9);
      const Eigen::Vector3d p(c.x() + r * std::cos(a), c.y() + r * std::sin(a), z);
      cloud.push_back({p.cast<float>(), Eigen::Vector3f(0, 0, 1.3f), cv::Vec3b(80, 90, 100), 0});
    }
    const StemsResult res = DetectWithoutBearingSplit(cloud);
    ASSERT_EQ(res.stems.size(), 1u);
    EXPECT_LT((res.stems[0].centre_xy - c).norm(), 0.03);
    EXPECT_LT(res.stems[0].lean_deg, 3.0);
    EXPECT_FALSE(res.stems[0].weak_support);
  }
}

// A near trunk whose breast-height slice came out flattened and bowed toward the cameras (as
// stereo on a thin near stem can): a circle fitted to that slice alone bulges the other way, its
// centre in front of the face. The band's circle stands instead.
TEST(Stems, ASliceBowedTowardTheCamerasKeepsTheBandsCircle) {
  Rng rng(9);
  std::vector<dense::CloudPoint> cloud = FlatGround(&rng);
  auto add = [&](const Eigen::Vector3d& p) {
    cloud.push_back({p.cast<float>(), Eigen::Vector3f(0, 0, 1.3f), cv::Vec3b(80, 90, 100), 0});
  };
  const Eigen::Vector2d c(0.54, 2.0);
  const double r = 0.0825, bearing = std::atan2(c.y(), c.x());
  const Eigen::Vector2d toward = -c.normalized(), across(-toward.y(), toward.x());
  for (int i = 0; i < 20000; ++i) {
    const double a = rng.Uniform(-1.1, 1.1), z = rng.Uniform(0.9, 1.8);
    if (std::abs(z - 1.37) < 0.06) {
      // The slice: the face's width, on a circle of 0.45 m whose centre lies toward the cameras.
      const double w = r * std::sin(a);
      const double bow = 0.45 - std::sqrt(0.45 * 0.45 - w * w);
      const Eigen::Vector2d q = c + toward * (r * std::cos(1.1) + bow) + across * w;
      add(Eigen::Vector3d(q.x(), q.y(), z));
    } else {
      const double phi = bearing + M_PI + a;
      add(Eigen::Vector3d(c.x() + r * std::cos(phi), c.y() + r * std::sin(phi), z));
    }
  }
  const GroundGrid ground(cloud, 13);
  const StemsResult res = DetectStems(StemOptions(), cloud, ground, 500.0);
  ASSERT_EQ(res.stems.size(), 1u);
  EXPECT_LT((res.stems[0].centre_xy - c).norm(), 0.03);
  EXPECT_NEAR(res.stems[0].dbh_circle_m, 2 * r, 0.03);
}

// Two trunks 4 m out, one upright and one leaning 11°: both are found, the leaning one left for
// two-sided silhouettes to confirm (weak_support), the upright one not.
TEST(Stems, ALeaningPartNeedsConfirming) {
  Rng rng(7);
  std::vector<dense::CloudPoint> cloud = FlatGround(&rng);
  const double lean = 11.0 * M_PI / 180.0;
  for (const auto& [c, tilt] :
       {std::pair{Eigen::Vector2d(4, 0), 0.0}, std::pair{Eigen::Vector2d(0, 4), lean}}) {
    const double bearing = std::atan2(c.y(), c.x());
    for (int i = 0; i < kTrunkPoints; ++i) {
      const double a = bearing + M_PI + rng.Uniform(-1.2, 1.2), z = rng.Uniform(0.2, 2.6);
      // Leaning away from the centre: the axis moves outward by tan(lean) per metre up.
      const Eigen::Vector2d axis = c + std::tan(tilt) * (z - 1.3) * c.normalized();
      AddSeenFromArm(
          Eigen::Vector3d(axis.x() + 0.15 * std::cos(a), axis.y() + 0.15 * std::sin(a), z), &rng,
          &cloud);
    }
  }
  const StemsResult res = DetectWithoutBearingSplit(cloud);
  ASSERT_EQ(res.stems.size(), 2u);
  for (const Stem& s : res.stems) {
    const bool leaning = s.centre_xy.y() > 2.0;
    EXPECT_NEAR(s.lean_deg, leaning ? 11.0 : 0.0, 2.0);
    EXPECT_EQ(s.weak_support, leaning);
  }
}

// Two thin far trunks two degrees apart from the centre and 1 m apart in range, with stray depths
// bridging them: stereo smears them into one part that no single stem fits. Its dense cores are
// kept as alternatives, one at each trunk.
TEST(Stems, SmearedPartOfTrunksInLineKeepsTheirCores) {
  Rng rng(8);
  std::vector<dense::CloudPoint> cloud = FlatGround(&rng);
  auto add = [&](double range, double bearing, double z) {
    AddSeenFromArm(Eigen::Vector3d(range * std::cos(bearing), range * std::sin(bearing), z), &rng,
                   &cloud);
  };
  struct Trunk {
    double range, bearing, r;
  };
  const std::vector<Trunk> trunks = {{8.2, -0.017, 0.08}, {9.15, -0.052, 0.07}};
  for (const Trunk& t : trunks) {
    for (int i = 0; i < 5000; ++i) {
      const double a = rng.Uniform(-1.3, 1.3);  // the face toward the centre
      const double range = t.range - t.r * std::cos(a) + rng.Normal(0, 0.06);
      add(range, t.bearing + t.r * std::sin(a) / t.range, rng.Uniform(0, 3));
    }
  }
  for (int i = 0; i < 3000; ++i) {  // stray depths between them, at the band's heights
    const double range = rng.Uniform(8.3, 9.05), bearing = rng.Uniform(-0.045, -0.025);
    add(range, bearing, rng.Uniform(1.0, 2.0));
  }
  const StemsResult res = DetectWithoutBearingSplit(cloud);
  ASSERT_EQ(res.stems.size(), 1u);
  const Stem& whole = res.stems[0];
  EXPECT_TRUE(whole.depth_smeared);
  ASSERT_GE(whole.alternatives.size(), 2u);
  for (const Trunk& t : trunks) {
    const Eigen::Vector2d c = t.range * Eigen::Vector2d(std::cos(t.bearing), std::sin(t.bearing));
    const bool found = std::ranges::any_of(whole.alternatives, [&](const Stem& a) {
      const double bearing = std::atan2(a.centre_xy.y(), a.centre_xy.x());
      return std::abs(bearing - t.bearing) < 0.006 && (a.centre_xy - c).norm() < 0.2;
    });
    EXPECT_TRUE(found) << "trunk at " << t.range << " m";
  }
  EXPECT_TRUE(DetectWithoutBearingSplit(cloud, false).stems[0].alternatives.empty());
}

// A near trunk with a shrub against its side: one part, wider than the trunk, that a silhouette
// fit of the whole would miss. Its dense core is the trunk alone.
TEST(Stems, PartOfATrunkAndAShrubKeepsTheTrunksCore) {
  Rng rng(9);
  std::vector<dense::CloudPoint> cloud = FlatGround(&rng);
  auto add = [&](const Eigen::Vector3d& p) { AddSeenFromArm(p, &rng, &cloud); };
  const Eigen::Vector2d trunk(2.5, 0.0);
  const double r = 0.08;
  for (int i = 0; i < 6000; ++i) {  // the face toward the centre, depth noise of 5 mm
    const double a = M_PI + rng.Uniform(-1.3, 1.3), rr = r + rng.Normal(0, 0.005);
    add(Eigen::Vector3d(trunk.x() + rr * std::cos(a), trunk.y() + rr * std::sin(a),
                        rng.Uniform(0, 3)));
  }
  for (int i = 0; i < 2500; ++i) {  // a shrub's twigs and leaves beside it, up to 1.8 m
    const double a = rng.Uniform(0, 2 * M_PI), d = 0.15 * std::sqrt(rng.Uniform(0, 1));
    add(Eigen::Vector3d(trunk.x() + 0.05 + d * std::cos(a), 0.25 + d * std::sin(a),
                        rng.Uniform(0.3, 1.8)));
  }
  const StemsResult res = DetectWithoutBearingSplit(cloud);
  ASSERT_EQ(res.stems.size(), 1u);
  const Stem& whole = res.stems[0];
  EXPECT_FALSE(whole.depth_smeared);
  EXPECT_GT(whole.dbh_m, 2 * r + 0.05);  // the shrub widens the part
  const bool trunk_core = std::ranges::any_of(whole.alternatives, [&](const Stem& a) {
    return (a.centre_xy - trunk).norm() < 0.04 && std::abs(a.dbh_m - 2 * r) < 0.03;
  });
  EXPECT_TRUE(trunk_core);
}

// A trunk with a sapling 3 cm thick beside it, stray depths bridging the gap: one part, wider
// than the trunk and off its centre. Its denser cores are the trunk and the sapling; the sapling
// is too thin for a stem, so the trunk's core is the part's one alternative, and it is kept:
// when no silhouette fits the whole part, that core is the stem.
TEST(Stems, PartOfATrunkAndASaplingKeepsTheTrunksOneCore) {
  Rng rng(10);
  std::vector<dense::CloudPoint> cloud = FlatGround(&rng);
  auto add = [&](const Eigen::Vector3d& p) { AddSeenFromArm(p, &rng, &cloud); };
  const Eigen::Vector2d trunk(6.5, 0.4), sapling(6.5, 0.15);
  const double r = 0.085;
  auto add_face = [&](const Eigen::Vector2d& c, double radius, int n) {
    for (int i = 0; i < n; ++i) {  // the face toward the centre, depth noise of 1 cm
      const double a = std::atan2(-c.y(), -c.x()) + rng.Uniform(-1.3, 1.3);
      const double rr = radius + rng.Normal(0, 0.01);
      add(Eigen::Vector3d(c.x() + rr * std::cos(a), c.y() + rr * std::sin(a), rng.Uniform(0, 3)));
    }
  };
  add_face(trunk, r, 6000);
  add_face(sapling, 0.015, 2500);
  for (int i = 0; i < 60; ++i) {  // stray depths in the gap between them
    add(Eigen::Vector3d(trunk.x() + rng.Uniform(-0.04, 0.04), rng.Uniform(0.17, 0.31),
                        rng.Uniform(0.9, 2.1)));
  }
  const GroundGrid ground(cloud, 13);
  const StemsResult res = DetectStems(StemOptions(), cloud, ground);
  ASSERT_EQ(res.stems.size(), 1u);
  const Stem& whole = res.stems[0];
  EXPECT_GT(whole.dbh_m, 2 * r + 0.05);  // the sapling widens the part
  ASSERT_EQ(whole.alternatives.size(), 1u);
  EXPECT_LT((whole.alternatives[0].centre_xy - trunk).norm(), 0.04);
  EXPECT_NEAR(whole.alternatives[0].dbh_m, 2 * r, 0.03);
}

// Trunks standing in a thicket longer than any stem is wide, one behind another (understory
// that fills the gaps between them): the band makes one part of it all, too wide to be a stem,
// with no bearing gap to split it. Its denser cores are the trunks, each a stem on weak support
// (silhouettes must confirm it); the thicket alone yields no stem that is not weak.
TEST(Stems, TrunksInAThicketTooWideForAStemAreItsCores) {
  for (const double half_length_m : {1.2, 1.4, 1.6}) {
    SCOPED_TRACE(half_length_m);
    Rng rng(11);
    std::vector<dense::CloudPoint> cloud = FlatGround(&rng);
    auto add = [&](const Eigen::Vector3d& p) { AddSeenFromArm(p, &rng, &cloud); };
    const std::vector<std::pair<Eigen::Vector2d, double>> trunks = {{{6.0, 0.0}, 0.12},
                                                                    {{7.1, 0.3}, 0.07}};
    // The thicket: an ellipse along the line of sight, nearly as wide across it, its leaves seen
    // at every depth through its gaps, from 0.3 to 1.8 m.
    const Eigen::Vector2d centre(6.5, 0.15);
    const int twigs = static_cast<int>(8000 * half_length_m * half_length_m);
    for (int i = 0; i < twigs; ++i) {
      const double a = rng.Uniform(0, 2 * M_PI), d = std::sqrt(rng.Uniform(0, 1));
      add(Eigen::Vector3d(centre.x() + half_length_m * d * std::cos(a),
                          centre.y() + 0.8 * half_length_m * d * std::sin(a),
                          rng.Uniform(0.3, 1.8)));
    }
    const GroundGrid ground_of_thicket(cloud, 13);
    for (const Stem& s : DetectStems(StemOptions(), cloud, ground_of_thicket).stems) {
      EXPECT_TRUE(s.weak_support) << s.centre_xy.transpose();
    }
    for (const auto& [c, r] : trunks) {
      for (int i = 0; i < 6000; ++i) {  // the face toward the centre, depth noise of 5 mm
        const double a = std::atan2(-c.y(), -c.x()) + rng.Uniform(-1.3, 1.3);
        const double rr = r + rng.Normal(0, 0.005);
        add(Eigen::Vector3d(c.x() + rr * std::cos(a), c.y() + rr * std::sin(a), rng.Uniform(0, 3)));
      }
    }
    const GroundGrid ground(cloud, 13);
    StemOptions o;
    const StemsResult res = DetectStems(o, cloud, ground);
    for (const auto& [c, r] : trunks) {
      const auto found = std::ranges::find_if(res.stems, [&](const Stem& s) {
        return (s.centre_xy - c).norm() < 0.05 && std::abs(s.dbh_m - 2 * r) < 0.03;
      });
      ASSERT_NE(found, res.stems.end()) << c.transpose();
      EXPECT_TRUE(found->weak_support);
    }
    EXPECT_GE(res.mixed_part_cores, 2);
    // Without the cores, the part too wide is all the band has there.
    o.split_mixed_parts_into_cores = false;
    const StemsResult without = DetectStems(o, cloud, ground);
    EXPECT_EQ(without.mixed_part_cores, 0);
    EXPECT_TRUE(std::ranges::none_of(without.stems, [&](const Stem& s) {
      return (s.centre_xy - trunks[0].first).norm() < 0.05;
    }));
  }
}

// A trunk with a dense shrub against it at the bottom of the band: the part's lowest third is
// drawn toward the shrub, the part leans 20° (further than max_lean_deg) and is no stem. Its
// denser core is the trunk, kept on weak support. Swept over the shrub's side and density.
TEST(Stems, ATrunkWithAShrubAgainstItAtOneHeightIsItsCore) {
  for (const double side : {-1.0, 1.0}) {
    for (const int twigs : {4000, 6000}) {
      SCOPED_TRACE(::testing::Message() << "side " << side << ", " << twigs << " twigs");
      Rng rng(12);
      std::vector<dense::CloudPoint> cloud = FlatGround(&rng);
      auto add = [&](const Eigen::Vector3d& p) { AddSeenFromArm(p, &rng, &cloud); };
      const Eigen::Vector2d trunk(5.0, 0.0), shrub(4.95, side * 0.3);
      const double r = 0.09;
      for (int i = 0; i < 6000; ++i) {  // the face toward the centre, depth noise of 5 mm
        const double a = M_PI + rng.Uniform(-1.3, 1.3), rr = r + rng.Normal(0, 0.005);
        add(Eigen::Vector3d(trunk.x() + rr * std::cos(a), trunk.y() + rr * std::sin(a),
                            rng.Uniform(0, 3)));
      }
      for (int i = 0; i < twigs; ++i) {  // its leaves from 0.9 to 1.3 m
        const double a = rng.Uniform(0, 2 * M_PI), d = 0.22 * std::sqrt(rng.Uniform(0, 1));
        add(Eigen::Vector3d(shrub.x() + d * std::cos(a), shrub.y() + d * std::sin(a),
                            rng.Uniform(0.9, 1.3)));
      }
      const GroundGrid ground(cloud, 13);
      StemOptions o;
      const StemsResult res = DetectStems(o, cloud, ground);
      EXPECT_GE(res.rejected_vertical, 1);
      const auto found = std::ranges::find_if(res.stems, [&](const Stem& s) {
        return (s.centre_xy - trunk).norm() < 0.04 && std::abs(s.dbh_m - 2 * r) < 0.03;
      });
      ASSERT_NE(found, res.stems.end());
      EXPECT_TRUE(found->weak_support);
      EXPECT_TRUE(found->mixed_part_core);
      o.split_mixed_parts_into_cores = false;
      EXPECT_TRUE(std::ranges::none_of(DetectStems(o, cloud, ground).stems, [&](const Stem& s) {
        return (s.centre_xy - trunk).norm() < 0.1;
      }));
    }
  }
}
}  // namespace
}  // namespace stemmap::stems
