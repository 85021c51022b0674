#include "stemmap/track/vertical.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "stemmap/core/rng.h"

namespace stemmap::track {
namespace {

struct TestTrunk {
  Eigen::Vector3d base;
  Eigen::Vector3d axis;  // unit
  int edges;             // segments per view (furrows add to the two silhouettes)
};

// Segments of each trunk's edges in 90 keyframes on a unit circle about the z axis.
std::vector<Keyframe> SegmentsOfTrunks(const std::vector<TestTrunk>& trunks,
                                       const PinholeCamera& camera, SparseMap* map) {
  std::vector<double> phi;
  for (int k = 0; k < 90; ++k) phi.push_back(k * 2 * M_PI / 90);
  PlaceOnCircle(phi, 1.0, map);
  std::vector<Keyframe> keyframes;
  for (int k = 0; k < 90; ++k) {
    Keyframe kf;
    for (const TestTrunk& t : trunks) {
      // Edges side by side across the line of sight from the axis.
      const Eigen::Vector3d across = Eigen::Vector3d(t.base.y(), -t.base.x(), 0).normalized();
      for (int e = 0; e < t.edges; ++e) {
        const double offset = -0.15 + 0.3 * e / std::max(1, t.edges - 1);
        const Eigen::Vector3d a = t.base + offset * across;
        const Eigen::Vector3d b = a + 3.0 * t.axis;
        const Eigen::Vector3d pa = map->cam_from_world[k] * (a - map->centre_world[k]);
        const Eigen::Vector3d pb = map->cam_from_world[k] * (b - map->centre_world[k]);
        if (pa.z() < 1 || pb.z() < 1) continue;
        const Eigen::Vector2d ia = camera.ImageFromCam(pa), ib = camera.ImageFromCam(pb);
        if (ia.x() < 0 || ia.x() > camera.width - 1 || ib.x() < 0 || ib.x() > camera.width - 1) {
          continue;
        }
        kf.vertical_segments.emplace_back(ia.x(), ia.y(), ib.x(), ib.y());
      }
    }
    keyframes.push_back(kf);
  }
  return keyframes;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, a.normalized().dot(b.normalized()))) * 180 / M_PI;
}

// A few near trunks leaning the same way, seen large with many edges in every view, and many
// far vertical ones: each trunk counts once, so the near ones cannot drag the vertical along.
TEST(Vertical, NearTrunksWithManyEdgesDoNotOutvoteTheFarOnes) {
  const PinholeCamera camera = PinholeCamera::FromHfov(640, 360, 67.0);
  const Eigen::Vector3d lean =
      Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()) * Eigen::Vector3d::UnitZ();
  std::vector<TestTrunk> trunks;
  for (int i = 0; i < 4; ++i) {
    const double a = i * M_PI / 2 + 0.3;
    trunks.push_back({Eigen::Vector3d(3 * std::cos(a), 3 * std::sin(a), -1.3), lean, 12});
  }
  Rng rng(9);
  for (int i = 0; i < 50; ++i) {
    const double a = rng.Uniform(0, 2 * M_PI), r = rng.Uniform(8, 25);
    trunks.push_back(
        {Eigen::Vector3d(r * std::cos(a), r * std::sin(a), -1.3), Eigen::Vector3d::UnitZ(), 2});
  }
  SparseMap map;
  const std::vector<Keyframe> keyframes = SegmentsOfTrunks(trunks, camera, &map);
  const VerticalEstimate v = EstimateVertical({}, keyframes, map, camera);
  ASSERT_TRUE(v.found);
  // Four of 54 trunks lean 3°: their fair share is 0.22°; by segments it would be over 1°.
  EXPECT_LT(AngleDeg(v.up_axis, Eigen::Vector3d::UnitZ()), 0.35);
  // Far trunks in line from some camera may share a group; most stand apart.
  EXPECT_GE(v.trunks, 20);
}

TEST(Vertical, RaysThroughOneTrunkFormOneGroup) {
  // Rays from points on the unit circle toward two trunks, and one stray ray.
  std::vector<Eigen::Vector2d> origins, directions;
  for (const Eigen::Vector2d& trunk : {Eigen::Vector2d(6, 1), Eigen::Vector2d(-4, 9)}) {
    for (int k = -3; k <= 3; ++k) {
      const double phi = std::atan2(trunk.y(), trunk.x()) + 0.15 * k;
      origins.emplace_back(std::cos(phi), std::sin(phi));
      directions.push_back((trunk - origins.back()).normalized());
    }
  }
  origins.emplace_back(1, 0);
  directions.emplace_back(0, -1);
  std::vector<int> views(origins.size());
  for (size_t i = 0; i < views.size(); ++i) views[i] = static_cast<int>(i);
  const std::vector<int> g = GroupRaysByTrunk({}, origins, directions, views);
  for (int i = 1; i < 7; ++i) EXPECT_EQ(g[i], g[0]);
  for (int i = 8; i < 14; ++i) EXPECT_EQ(g[i], g[7]);
  EXPECT_NE(g[0], g[7]);
  EXPECT_NE(g[14], g[0]);
  EXPECT_NE(g[14], g[7]);
}

// Every ray of a view starts at its camera, so many edges in one view meet just in front of it;
// a trunk is where rays of several views meet. Fans of rays from four views a quarter turn apart,
// toward things each view alone sees: no group.
TEST(Vertical, RaysOfOneViewDoNotMakeATrunk) {
  std::vector<Eigen::Vector2d> origins, directions;
  std::vector<int> views;
  for (int k = 0; k < 4; ++k) {
    const double phi = k * M_PI / 2;
    for (int i = 0; i < 40; ++i) {
      const double a = phi + (-25.0 + 50.0 * i / 39) * M_PI / 180;
      origins.emplace_back(std::cos(phi), std::sin(phi));
      directions.emplace_back(std::cos(a), std::sin(a));
      views.push_back(k);
    }
  }
  std::vector<int> g = GroupRaysByTrunk({}, origins, directions, views);
  std::ranges::sort(g);
  EXPECT_EQ(std::ranges::unique(g).begin(), g.end());  // every ray its own group
}

// Vertical trunks seen from cameras on a circle whose axis is tilted 1° from the vertical: the
// estimate must find the true vertical, not the axis.
TEST(Vertical, FindsTheVerticalOfAStandOnATiltedAxis) {
  const PinholeCamera camera = PinholeCamera::FromHfov(640, 360, 67.0);
  const Eigen::Vector3d up_true =
      Eigen::AngleAxisd(1.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()) * Eigen::Vector3d::UnitZ();
  Rng rng(4);
  std::vector<TestTrunk> trunks;
  for (int i = 0; i < 60; ++i) {
    const double a = rng.Uniform(0, 2 * M_PI), r = rng.Uniform(3, 20);
    trunks.push_back({Eigen::Vector3d(r * std::cos(a), r * std::sin(a), -1.3), up_true, 2});
  }
  SparseMap map;
  const std::vector<Keyframe> keyframes = SegmentsOfTrunks(trunks, camera, &map);
  const VerticalEstimate v = EstimateVertical({}, keyframes, map, camera);
  ASSERT_TRUE(v.found);
  EXPECT_LT(AngleDeg(v.up_axis, up_true), 0.02);
  EXPECT_NEAR(v.tilt_deg, 1.0, 0.02);
}

TEST(Vertical, TooFewSegments) {
  SparseMap map;
  PlaceOnCircle({0.0}, 1.0, &map);
  EXPECT_FALSE(EstimateVertical({}, {Keyframe{}}, map, PinholeCamera::FromHfov(64, 36, 60)).found);
}

}  // namespace
}  // namespace stemmap::track
