#include "stemmap/stems/ground.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"

namespace stemmap::stems {
namespace {

// Uneven ground: a slope and broad mounds and hollows (up to ±0.8 m, 1.5-4 m wide), all of
// them beyond `bumps_from_m` plus twice their width from the plot centre.
struct Terrain {
  double slope_x = 0.0, slope_y = 0.0;
  std::vector<Eigen::Vector4d> bumps;  // x, y, height, width
  double Height(double x, double y) const {
    double z = slope_x * x + slope_y * y;
    for (const Eigen::Vector4d& b : bumps) {
      z += b.z() *
           std::exp(-(std::pow(x - b.x(), 2) + std::pow(y - b.y(), 2)) / (2 * b.w() * b.w()));
    }
    return z;
  }
};

Terrain MakeTerrain(Rng* rng, double slope_deg, double bumps_from_m) {
  Terrain t;
  const double a = rng->Uniform(0, 2 * M_PI), g = std::tan(slope_deg * M_PI / 180);
  t.slope_x = g * std::cos(a);
  t.slope_y = g * std::sin(a);
  for (int i = 0; i < 12; ++i) {
    const double b = rng->Uniform(0, 2 * M_PI), width = rng->Uniform(1.5, 4.0);
    const double r = rng->Uniform(std::min(bumps_from_m + 2 * width, 12.0), 13);
    t.bumps.emplace_back(r * std::cos(b), r * std::sin(b), rng->Uniform(-0.8, 0.8), width);
  }
  return t;
}

// Replaces the terrain's mounds and hollows by `count` bumps of up to ±`height_m`, `width_lo_m` to
// `width_hi_m` wide, centred `r_lo_m` to `r_hi_m` from the plot centre.
void SetBumps(Terrain* t, Rng* rng, int count, double r_lo_m, double r_hi_m, double height_m,
              double width_lo_m, double width_hi_m) {
  t->bumps.clear();
  for (int i = 0; i < count; ++i) {
    const double b = rng->Uniform(0, 2 * M_PI), r = rng->Uniform(r_lo_m, r_hi_m);
    t->bumps.emplace_back(r * std::cos(b), r * std::sin(b), rng->Uniform(-height_m, height_m),
                          rng->Uniform(width_lo_m, width_hi_m));
  }
}

dense::CloudPoint At(double x, double y, double z) {
  return {Eigen::Vector3f(x, y, z), Eigen::Vector3f(0, 0, 1.3f), cv::Vec3b(60, 70, 80), 0};
}

// What stereo sees of a plot with understory: the ground 3-12 m out where nothing stands on it
// (3 cm noise), shrubs and sapling crowns 0.3-1.5 m tall over `cover` of it (their leaves, mostly
// the upper ones, and now and then the ground between them), and stems with their bark down to
// the ground.
std::vector<dense::CloudPoint> Understory(const Terrain& t, double cover, Rng* rng,
                                          std::vector<Eigen::Vector3d>* stems) {
  std::vector<Eigen::Vector4d> shrubs;  // x, y, radius, height
  double area = 0.0;
  while (area < cover * M_PI * (144 - 4)) {
    const double a = rng->Uniform(0, 2 * M_PI), r = rng->Uniform(2, 12);
    shrubs.emplace_back(r * std::cos(a), r * std::sin(a), rng->Uniform(0.5, 1.5),
                        rng->Uniform(0.3, 1.5));
    area += M_PI * shrubs.back().z() * shrubs.back().z() * 0.8;  // they overlap a little
  }
  std::vector<dense::CloudPoint> cloud;
  for (int i = 0; i < 150000; ++i) {
    const double a = rng->Uniform(0, 2 * M_PI), r = std::sqrt(rng->Uniform(9, 144));
    const double x = r * std::cos(a), y = r * std::sin(a), ground = t.Height(x, y);
    const Eigen::Vector4d* over = nullptr;
    for (const Eigen::Vector4d& s : shrubs) {
      if (std::hypot(x - s.x(), y - s.y()) < s.z()) over = &s;
    }
    if (over == nullptr || rng->Uniform() < 0.05) {
      cloud.push_back(At(x, y, ground + rng->Normal(0, 0.03)));
    } else {
      cloud.push_back(At(x, y, ground + over->w() * (1 - 0.7 * std::pow(rng->Uniform(), 3))));
    }
  }
  for (int k = 0; k < 15; ++k) {
    const double a = rng->Uniform(0, 2 * M_PI), r = rng->Uniform(3, 11);
    stems->emplace_back(r * std::cos(a), r * std::sin(a), rng->Uniform(0.08, 0.3));
    const Eigen::Vector3d& s = stems->back();
    const double base = t.Height(s.x(), s.y());
    for (int i = 0; i < 3000; ++i) {
      const double b = rng->Uniform(0, 2 * M_PI);
      cloud.push_back(
          At(s.x() + s.z() * std::cos(b), s.y() + s.z() * std::sin(b), base + rng->Uniform(0, 3)));
    }
  }
  return cloud;
}

// The grid's ground at each stem within 10 cm of the terrain's, and within 5 cm rms.
void ExpectGroundAtStems(const GroundGrid& grid, const Terrain& terrain,
                         const std::vector<Eigen::Vector3d>& stems) {
  double sum_sq = 0.0;
  for (const Eigen::Vector3d& s : stems) {
    const double e = grid.Height(s.x(), s.y()) - terrain.Height(s.x(), s.y());
    EXPECT_LT(std::abs(e), 0.1) << "stem at " << s.transpose();
    sum_sq += e * e;
  }
  EXPECT_LT(std::sqrt(sum_sq / stems.size()), 0.05);
}

// The ground at each stem, under shrubs and on mounds, over covers and slopes.
TEST(GroundGrid, TheGroundAtEachStemUnderUnderstory) {
  for (double cover : {0.3, 0.6}) {
    for (double slope_deg : {2.0, 10.0}) {
      for (uint64_t seed : {1, 2}) {
        SCOPED_TRACE(::testing::Message()
                     << "cover " << cover << ", slope " << slope_deg << "°, seed " << seed);
        Rng rng(seed);
        const Terrain terrain = MakeTerrain(&rng, slope_deg, 0.0);
        std::vector<Eigen::Vector3d> stems;
        const GroundGrid grid(Understory(terrain, cover, &rng, &stems), 13);
        ExpectGroundAtStems(grid, terrain, stems);
      }
    }
  }
}

// What the outward-facing camera on the arm (radius 1 m, `camera_z` above the tripod's ground)
// sees near the tripod: no ground within ~4.7 m (its view's bottom edge dips 20°), each near
// stem's bark and shrub's leaves only down to where that edge cuts them, and the ground beyond;
// what lies at the edge is marked at_view_bottom.
std::vector<dense::CloudPoint> NearTheTripod(const Terrain& t, double camera_z, Rng* rng,
                                             std::vector<Eigen::Vector3d>* stems,
                                             double edge_dip_deg = 20.0) {
  const double tan_edge = std::tan(edge_dip_deg * M_PI / 180.0), arm_m = 1.0;
  const double eye_z = t.Height(0, 0) + camera_z;
  // The lowest height the nearest camera sees at `r` from the centre.
  auto lowest_seen = [&](double r) { return eye_z - (r - arm_m) * tan_edge; };
  std::vector<dense::CloudPoint> cloud;
  // A point seen from the camera on the arm at its azimuth; within the bottom 4 % of a 43°-high
  // view above the lowest height that camera sees there: at its view's bottom edge. Its depth
  // noise (`noise_m`, here vertical) comes after: the view's edge cuts by direction, so a point
  // seen is kept however far its noise moves it.
  auto seen = [&](double x, double y, double z, double noise_m = 0.0) {
    if (z < lowest_seen(std::hypot(x, y))) return;
    const double cut = 0.03 * (std::hypot(x, y) - arm_m);
    const double a = std::atan2(y, x);
    cloud.push_back({Eigen::Vector3f(x, y, z + noise_m),
                     Eigen::Vector3f(arm_m * std::cos(a), arm_m * std::sin(a), eye_z),
                     cv::Vec3b(60, 70, 80), 0});
    cloud.back().at_view_bottom = z < lowest_seen(std::hypot(x, y)) + cut;
  };
  for (int i = 0; i < 150000; ++i) {
    const double a = rng->Uniform(0, 2 * M_PI), r = std::sqrt(rng->Uniform(4, 144));
    const double x = r * std::cos(a), y = r * std::sin(a);
    seen(x, y, t.Height(x, y), rng->Normal(0, 0.03));
  }
  for (int k = 0; k < 25; ++k) {  // shrubs 0.4-1.2 m tall
    const double a = rng->Uniform(0, 2 * M_PI), r = rng->Uniform(1.5, 4.7);
    const double x = r * std::cos(a), y = r * std::sin(a), radius = rng->Uniform(0.3, 0.8);
    const double top = t.Height(x, y) + rng->Uniform(0.4, 1.2);
    for (int i = 0; i < 2000; ++i) {
      const double b = rng->Uniform(0, 2 * M_PI), d = radius * std::sqrt(rng->Uniform());
      const double px = x + d * std::cos(b), py = y + d * std::sin(b);
      seen(px, py, top - 0.8 * (top - t.Height(px, py)) * std::pow(rng->Uniform(), 2));
    }
  }
  for (int k = 0; k < 12; ++k) {
    const double a = rng->Uniform(0, 2 * M_PI), r = rng->Uniform(1.6, 5.0);
    stems->emplace_back(r * std::cos(a), r * std::sin(a), rng->Uniform(0.05, 0.2));
    const Eigen::Vector3d& s = stems->back();
    const double base = t.Height(s.x(), s.y());
    const double low = std::max(base, lowest_seen(r - s.z()));
    for (int i = 0; i < 3000; ++i) {
      // The half of the bark that faces the tripod.
      const double b = std::atan2(-s.y(), -s.x()) + rng->Uniform(-M_PI / 2, M_PI / 2);
      seen(s.x() + s.z() * std::cos(b), s.y() + s.z() * std::sin(b),
           low + rng->Uniform(0, base + 3.0 - low));
    }
  }
  return cloud;
}

// A stem within ~4.7 m of the tripod shows its bark only down to where the view's bottom edge
// cuts it, and the shrubs about it theirs: none of that is ground, and the ground there comes
// from the ground beyond. Over slopes (mounds and hollows farther out: those under the tripod
// are out of sight).
TEST(GroundGrid, TheGroundAtAStemNearTheTripodIsNotItsLowestBark) {
  for (double slope_deg : {0.0, 4.0, 8.0}) {
    for (uint64_t seed : {3, 4}) {
      SCOPED_TRACE(::testing::Message() << "slope " << slope_deg << "°, seed " << seed);
      Rng rng(seed);
      const Terrain terrain = MakeTerrain(&rng, slope_deg, 12.0);
      std::vector<Eigen::Vector3d> stems;
      const std::vector<dense::CloudPoint> cloud = NearTheTripod(terrain, 1.37, &rng, &stems);
      const GroundGrid grid(cloud, 13);
      int cut_off = 0;
      double sum_sq = 0.0;
      for (const Eigen::Vector3d& s : stems) {
        const double e = grid.Height(s.x(), s.y()) - terrain.Height(s.x(), s.y());
        // The nearest stems lie 2-3 m from the nearest ground seen: 5-8 cm off there.
        EXPECT_LT(std::abs(e), 0.1) << "stem at " << s.transpose();
        sum_sq += e * e;
        cut_off += s.head<2>().norm() < 4.0;
      }
      EXPECT_LT(std::sqrt(sum_sq / stems.size()), 0.05);
      ASSERT_GE(cut_off, 3) << "the scene puts stems where the view's edge cuts their bark";
      // Unmarked, the lowest bark would pass for ground.
      std::vector<dense::CloudPoint> unmarked = cloud;
      for (dense::CloudPoint& p : unmarked) p.at_view_bottom = false;
      const GroundGrid naive(unmarked, 13);
      double worst_m = 0.0;
      for (const Eigen::Vector3d& s : stems) {
        worst_m = std::max(worst_m, naive.Height(s.x(), s.y()) - terrain.Height(s.x(), s.y()));
      }
      EXPECT_GT(worst_m, 0.2);
    }
  }
}

// The same where the view's bottom edge dips less (14°: the ground shows from ~6 m out) and the
// ground seen is uneven at the scale of a metre (bumps of up to ±7 cm, 0.6-1.5 m wide, as on
// managed plots, from 6.5 m out) on a gentle slope: the nearest ground seen lies on one side of a
// stem near the tripod, 4-5 m from it, and its bumps must not tilt the ground carried in.
TEST(GroundGrid, TheGroundAtAStemNearTheTripodDoesNotTiltWithBumpsBeyond) {
  for (double slope_deg : {0.0, 3.0}) {
    for (uint64_t seed : {5, 6, 7}) {
      SCOPED_TRACE(::testing::Message() << "slope " << slope_deg << "°, seed " << seed);
      Rng rng(seed);
      Terrain terrain = MakeTerrain(&rng, slope_deg, 12.0);
      SetBumps(&terrain, &rng, 120, 6.5, 13.0, 0.07, 0.6, 1.5);
      std::vector<Eigen::Vector3d> stems;
      const std::vector<dense::CloudPoint> cloud =
          NearTheTripod(terrain, 1.32, &rng, &stems, /*edge_dip_deg=*/14.0);
      const GroundGrid grid(cloud, 13);
      ExpectGroundAtStems(grid, terrain, stems);
    }
  }
}

// Under the tripod the camera sees no ground within ~3.5 m: the ground around is carried in, which
// holds where the terrain is smooth over that disc (a slope; mounds and hollows farther out). A
// mound or hollow under the tripod is out of sight: --camera-height is the answer to it.
TEST(GroundGrid, TheGroundUnderTheTripodFromTheGroundAround) {
  for (double slope_deg : {0.0, 5.0, 10.0}) {
    for (uint64_t seed : {7, 8}) {
      SCOPED_TRACE(::testing::Message() << "slope " << slope_deg << "°, seed " << seed);
      Rng rng(seed);
      const Terrain terrain = MakeTerrain(&rng, slope_deg, 6.0);
      std::vector<Eigen::Vector3d> stems;
      const GroundGrid grid(Understory(terrain, 0.5, &rng, &stems), 13);
      EXPECT_NEAR(grid.Height(0, 0), terrain.Height(0, 0), 0.05);
      EXPECT_NEAR(grid.AxisHeight(), terrain.Height(0, 0), 0.05);
      // The plot's slope, and which way it falls, from the ground within 8 m.
      const GroundGrid::Slope slope = grid.PlaneSlope(8.0);
      EXPECT_NEAR(slope.slope_deg, slope_deg, 1.0);
      if (slope_deg > 0) {
        const double downhill_deg = std::atan2(-terrain.slope_y, -terrain.slope_x) * 180 / M_PI;
        EXPECT_NEAR(std::remainder(slope.downhill_azimuth_deg - downhill_deg, 360.0), 0.0, 10.0);
      }
    }
  }
}

// Dense stereo of bare, uneven ground (a slope of 3-8° and bumps of ±15 cm, 2-4 m wide, as on
// natural plots): `per_m2` points a square metre with `noise_m` depth noise. A cell's lowest
// layer is an extreme of that noise, lower the more points the cell holds, and a layer on a
// slope holds only the cell's downhill part: its height alone lies centimetres low (1-4 cm
// here). With the cells centred on their points (GroundOptions::refine_iterations), the grid
// comes back to the points about its own surface, so bare ground is as high as they say: the
// mean error over the ring 4-10 m out stays within 1 cm, whatever the density and noise.
TEST(GroundGrid, CentredCellsReadDenseNoisyGroundOnASlopeAsHighAsItIs) {
  for (double slope_deg : {3.0, 8.0}) {
    for (double noise_m : {0.02, 0.04}) {
      for (int per_m2 : {300, 1500}) {
        SCOPED_TRACE(::testing::Message() << "slope " << slope_deg << "°, noise " << noise_m
                                          << " m, " << per_m2 << " points/m²");
        Rng rng(11);
        Terrain terrain = MakeTerrain(&rng, slope_deg, 12.0);
        SetBumps(&terrain, &rng, 60, 0.0, 13.0, 0.15, 1.0, 2.0);
        std::vector<dense::CloudPoint> cloud;
        const int n = static_cast<int>(per_m2 * M_PI * (144 - 9));
        for (int i = 0; i < n; ++i) {
          const double a = rng.Uniform(0, 2 * M_PI), r = std::sqrt(rng.Uniform(9, 144));
          const double x = r * std::cos(a), y = r * std::sin(a);
          cloud.push_back(At(x, y, terrain.Height(x, y) + rng.Normal(0, noise_m)));
        }
        GroundOptions centred;
        centred.refine_iterations = 3;
        const GroundGrid grid(cloud, 13, centred);
        double sum_m = 0.0, sum_sq = 0.0, floor_sum_m = 0.0;
        int count = 0;
        for (double x = -10; x <= 10; x += 0.25) {
          for (double y = -10; y <= 10; y += 0.25) {
            const double r = std::hypot(x, y);
            if (r < 4 || r > 10) continue;
            const double e = grid.Height(x, y) - terrain.Height(x, y);
            sum_m += e;
            sum_sq += e * e;
            floor_sum_m += grid.FloorHeight(x, y) - terrain.Height(x, y);
            ++count;
          }
        }
        EXPECT_LT(std::abs(sum_m / count), 0.01);
        EXPECT_LT(std::sqrt(sum_sq / count), 0.02);
        // The floors detection measures heights from lie lower.
        EXPECT_LT(floor_sum_m, sum_m);
      }
    }
  }
}

// On a slope a stem's breast height is measured from the ground on its uphill side: as high above
// the ground at its axis as the slope rises over its radius, and no higher on flat ground.
TEST(GroundGrid, TheGroundOnAStemsUphillSideRisesWithTheSlopeOverItsRadius) {
  for (double slope_deg : {0.0, 5.0, 15.0}) {
    for (double radius_m : {0.05, 0.2, 0.4}) {
      SCOPED_TRACE(::testing::Message() << "slope " << slope_deg << "°, radius " << radius_m);
      Rng rng(21);
      Terrain terrain = MakeTerrain(&rng, slope_deg, 20.0);
      terrain.bumps.clear();
      std::vector<dense::CloudPoint> cloud;
      for (int i = 0; i < 100000; ++i) {
        const double a = rng.Uniform(0, 2 * M_PI), r = std::sqrt(rng.Uniform(9, 144));
        const double x = r * std::cos(a), y = r * std::sin(a);
        cloud.push_back(At(x, y, terrain.Height(x, y)));
      }
      const GroundGrid grid(cloud, 13);
      const double rise_m = std::tan(slope_deg * M_PI / 180) * radius_m;
      for (const Eigen::Vector2d& xy : {Eigen::Vector2d(6, 0), Eigen::Vector2d(-4, 5)}) {
        EXPECT_NEAR(grid.UphillHeight(xy.x(), xy.y(), radius_m) - grid.Height(xy.x(), xy.y()),
                    rise_m, 0.1 * rise_m + 0.002);
      }
    }
  }
}

// The view-bottom, see-under, fill and refinement options out of their range are input errors.
TEST(GroundOptions, CutOffSeenUnderFillAndRefineOptionsOutOfRangeAreRefused) {
  auto refused = [](auto change) {
    GroundOptions o;
    change(&o);
    try {
      o.Check();
    } catch (const InputError&) {
      return true;
    }
    return false;
  };
  EXPECT_FALSE(refused([](GroundOptions*) {}));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->max_floor_at_view_bottom = 1.5; }));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->max_floor_at_view_bottom = -0.1; }));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->min_rays_under_floor = -1; }));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->max_pass_under_floor_m = -0.1; }));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->pass_end_clearance_m = -1; }));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->fill_one_sided_m = 0; }));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->fill_slope_prior = -1; }));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->refine_below_m = 0; }));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->refine_above_m = -0.1; }));
  EXPECT_TRUE(refused([](GroundOptions* o) { o->refine_iterations = -1; }));
  EXPECT_FALSE(refused([](GroundOptions* o) { o->refine_iterations = 0; }));
}

}  // namespace
}  // namespace stemmap::stems
