#include "stemmap/track/bundle_adjustment.h"

#include <gtest/gtest.h>

#include <limits>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"

namespace stemmap::track {
namespace {

// A known world: cameras on a 1 m arm turning 1.1 times, a mount a little off nominal, points
// scattered 3-15 m from the axis; tracks are their noisy projections.
struct SyntheticRig {
  PinholeCamera camera = PinholeCamera::FromHfov(640, 360, 67.0);
  SparseMap truth;
  std::vector<Track> tracks;
  std::vector<double> phi;

  explicit SyntheticRig(uint64_t seed) {
    Rng rng(seed);
    const int n_kf = 80;
    const Eigen::Quaterniond mount =
        NominalArmFromCam() * Eigen::Quaterniond(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitX()));
    for (int k = 0; k < n_kf; ++k) {
      phi.push_back(k * 2.2 * M_PI / n_kf);  // 1.1 turns
      const Eigen::Quaterniond rz(Eigen::AngleAxisd(phi.back(), Eigen::Vector3d::UnitZ()));
      truth.cam_from_world.push_back((rz * mount).conjugate());
      // Arm flex moves the camera off the circle; not the first, which fixes the yaw gauge.
      const double flex_m = k == 0 ? 0.0 : 0.003;
      truth.centre_world.push_back(Eigen::Vector3d(std::cos(phi.back()), std::sin(phi.back()), 0) +
                                   flex_m *
                                       Eigen::Vector3d(rng.Normal(), rng.Normal(), rng.Normal()));
    }
    truth.arm_from_cam = mount;
    for (int i = 0; i < 2500; ++i) {
      const double a = rng.Uniform(0, 2 * M_PI), r = rng.Uniform(3, 15);
      const Eigen::Vector3d x(r * std::cos(a), r * std::sin(a), rng.Uniform(-1.3, 2.0));
      Track t;
      for (int k = 0; k < n_kf; ++k) {
        const Eigen::Vector3d p = truth.cam_from_world[k] * (x - truth.centre_world[k]);
        if (p.z() < 0.5) continue;
        const Eigen::Vector2d px =
            camera.ImageFromCam(p) + 0.3 * Eigen::Vector2d(rng.Normal(), rng.Normal());
        if (px.x() < 0 || px.y() < 0 || px.x() > 639 || px.y() > 359) continue;
        t.obs.push_back({k, px});
      }
      if (t.obs.size() >= 3) {
        tracks.push_back(t);
        truth.point_world.push_back(x);
      }
    }
  }
};

TEST(BundleAdjustment, RecoversTheCircleFromAPerturbedStart) {
  SyntheticRig rig(5);
  Rng rng(9);
  std::vector<double> phi0 = rig.phi;
  for (size_t k = 1; k < phi0.size(); ++k) phi0[k] += rng.Normal(0.0, 0.01);  // ~0.6° off
  SparseMap map;
  PlaceOnCircle(phi0, 1.0, &map);
  BundleOptions o;
  o.max_points = 2000;
  BundleSummary s;
  for (int round = 0; round < 3; ++round) {
    TriangulateTracks(o, rig.tracks, rig.camera, &map);
    s = RunBundleAdjustment(o, rig.tracks, rig.camera, &map);
  }
  EXPECT_LT(s.final_rms_px, 0.5);
  // Compared after a yaw-only alignment, as the benchmark does (the gauge is the first camera).
  double dot = 0, cross = 0;
  for (size_t k = 0; k < rig.phi.size(); ++k) {
    const Eigen::Vector3d &e = map.centre_world[k], &t = rig.truth.centre_world[k];
    dot += e.x() * t.x() + e.y() * t.y();
    cross += e.x() * t.y() - e.y() * t.x();
  }
  const Eigen::Quaterniond rz(Eigen::AngleAxisd(std::atan2(cross, dot), Eigen::Vector3d::UnitZ()));
  double max_pos = 0, max_rot = 0;
  for (size_t k = 0; k < rig.phi.size(); ++k) {
    max_pos = std::max(max_pos, (rz * map.centre_world[k] - rig.truth.centre_world[k]).norm());
    max_rot = std::max(max_rot, (rz * map.cam_from_world[k].conjugate())
                                    .angularDistance(rig.truth.cam_from_world[k].conjugate()));
  }
  EXPECT_LT(max_pos, 0.006);              // metres: scale comes from the arm radius alone
  EXPECT_LT(max_rot * 180 / M_PI, 0.05);  // degrees
  EXPECT_LT(map.arm_from_cam.angularDistance(rig.truth.arm_from_cam) * 180 / M_PI, 0.1);
}

TEST(BundleAdjustment, DenseAndSparseSchurAgree) {
  SyntheticRig rig(6);
  SparseMap dense_map, sparse_map;
  PlaceOnCircle(rig.phi, 1.0, &dense_map);
  PlaceOnCircle(rig.phi, 1.0, &sparse_map);
  BundleOptions o;
  o.max_points = 800;
  TriangulateTracks(o, rig.tracks, rig.camera, &dense_map);
  TriangulateTracks(o, rig.tracks, rig.camera, &sparse_map);
  RunBundleAdjustment(o, rig.tracks, rig.camera, &dense_map);
  o.dense_schur_max_keyframes = 0;
  RunBundleAdjustment(o, rig.tracks, rig.camera, &sparse_map);
  for (size_t k = 0; k < rig.phi.size(); ++k) {
    EXPECT_LT((dense_map.centre_world[k] - sparse_map.centre_world[k]).norm(), 1e-5);
  }
}

TEST(BundleAdjustment, RejectsBadOptions) {
  BundleOptions o;
  o.arm_radius_m = 0.0;
  EXPECT_ANY_THROW(o.Check());
  for (double tolerance : {0.0, -1e-6, 0.5, std::numeric_limits<double>::quiet_NaN()}) {
    BundleOptions t;
    t.function_tolerance = tolerance;
    EXPECT_THROW(t.Check(), InputError) << tolerance;
    t = BundleOptions();
    t.early_round_function_tolerance = tolerance;
    EXPECT_THROW(t.Check(), InputError) << tolerance;
  }
  BundleOptions no_iterations;
  no_iterations.max_iterations = 0;
  EXPECT_THROW(no_iterations.Check(), InputError);
}

}  // namespace
}  // namespace stemmap::track
