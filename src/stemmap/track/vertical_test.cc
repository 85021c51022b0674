#include "stemmap/track/vertical.h"

#include <gtest/gtest.h>

#include "stemmap/core/rng.h"

namespace stemmap::track {
namespace {

// Vertical trunks seen from cameras on a circle whose axis is tilted 1° from the vertical: the
// estimate must find the true vertical, not the axis.
TEST(Vertical, FindsTheVerticalOfAStandOnATiltedAxis) {
  const PinholeCamera camera = PinholeCamera::FromHfov(640, 360, 67.0);
  const Eigen::Vector3d up_true =
      Eigen::AngleAxisd(1.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()) * Eigen::Vector3d::UnitZ();
  Rng rng(4);
  std::vector<Eigen::Vector3d> trunks;
  for (int i = 0; i < 60; ++i) {
    const double a = rng.Uniform(0, 2 * M_PI), r = rng.Uniform(3, 20);
    trunks.emplace_back(r * std::cos(a), r * std::sin(a), -1.3);
  }
  SparseMap map;
  std::vector<Keyframe> keyframes;
  std::vector<double> phi;
  for (int k = 0; k < 90; ++k) phi.push_back(k * 2 * M_PI / 90);
  PlaceOnCircle(phi, 1.0, &map);
  for (int k = 0; k < 90; ++k) {
    Keyframe kf;
    for (const Eigen::Vector3d& base : trunks) {
      for (double side : {-0.15, 0.15}) {  // both silhouette edges, roughly
        const Eigen::Vector3d a = base + Eigen::Vector3d(side, 0, 0);
        const Eigen::Vector3d b = a + 3.0 * up_true;
        const Eigen::Vector3d pa = map.cam_from_world[k] * (a - map.centre_world[k]);
        const Eigen::Vector3d pb = map.cam_from_world[k] * (b - map.centre_world[k]);
        if (pa.z() < 1 || pb.z() < 1) continue;
        const Eigen::Vector2d ia = camera.ImageFromCam(pa), ib = camera.ImageFromCam(pb);
        if (ia.x() < 0 || ia.x() > 639 || ib.x() < 0 || ib.x() > 639) continue;
        kf.vertical_segments.emplace_back(ia.x(), ia.y(), ib.x(), ib.y());
      }
    }
    keyframes.push_back(kf);
  }
  const VerticalEstimate v = EstimateVertical({}, keyframes, {}, map, camera);
  ASSERT_TRUE(v.found);
  EXPECT_LT(std::acos(std::min(1.0, v.up_axis.dot(up_true))) * 180 / M_PI, 0.02);
  EXPECT_NEAR(v.tilt_deg, 1.0, 0.02);
}

TEST(Vertical, TooFewSegments) {
  SparseMap map;
  PlaceOnCircle({0.0}, 1.0, &map);
  EXPECT_FALSE(
      EstimateVertical({}, {Keyframe{}}, {}, map, PinholeCamera::FromHfov(64, 36, 60)).found);
}

}  // namespace
}  // namespace stemmap::track
