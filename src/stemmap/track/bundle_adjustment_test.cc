#include "stemmap/track/bundle_adjustment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <limits>
#include <optional>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"
#include "stemmap/track/track.h"

namespace stemmap::track {
namespace {

// Leaves that flutter: points between `min_r_m` and `max_r_m` from the axis, below `top_m` (axis
// frame), sit `amplitude_m` to one side of their place and then the other, keyframe by keyframe,
// across the line of sight. None by default.
struct RigSway {
  double amplitude_m = 0.0;
  double min_r_m = 0.0, max_r_m = 0.0, top_m = 0.0;
};

// A known world: cameras on a 1 m arm turning 1.1 times, a mount a little off nominal, points
// scattered 3-15 m from the axis; tracks are their noisy projections. Where `focal_scale_at` is
// given, each keyframe's focal length is that many times the camera's at its arm angle (rad), as
// an autofocus following near and far trunks would change it (truth.keyframe_focal_scale).
struct SyntheticRig {
  PinholeCamera camera;
  SparseMap truth;
  std::vector<Track> tracks;
  std::vector<double> phi;

  std::vector<char> sways;  // per track

  explicit SyntheticRig(uint64_t seed,
                        const std::function<double(double)>& focal_scale_at = nullptr,
                        const PinholeCamera& lens = PinholeCamera::FromHfov(640, 360, 67.0),
                        const RigSway& sway = {})
      : camera(lens) {
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
    for (int k = 0; k < n_kf; ++k) {
      truth.keyframe_focal_scale.push_back(focal_scale_at ? focal_scale_at(phi[k]) : 1.0);
    }
    for (int i = 0; i < 2500; ++i) {
      const double a = rng.Uniform(0, 2 * M_PI), r = rng.Uniform(3, 15);
      const Eigen::Vector3d x(r * std::cos(a), r * std::sin(a), rng.Uniform(-1.3, 2.0));
      const bool moves =
          sway.amplitude_m > 0.0 && r >= sway.min_r_m && r < sway.max_r_m && x.z() < sway.top_m;
      const Eigen::Vector3d across(-std::sin(a), std::cos(a), 0.0);
      Track t;
      for (int k = 0; k < n_kf; ++k) {
        const Eigen::Vector3d at =
            moves ? (x + (k % 2 ? 1.0 : -1.0) * sway.amplitude_m * across).eval() : x;
        const Eigen::Vector3d p = truth.cam_from_world[k] * (at - truth.centre_world[k]);
        if (p.z() < 0.5) continue;
        const Eigen::Vector2d centre(camera.cx, camera.cy);
        const Eigen::Vector2d px =
            centre + truth.keyframe_focal_scale[k] * (camera.ImageFromCam(p) - centre) +
            0.3 * Eigen::Vector2d(rng.Normal(), rng.Normal());
        if (px.x() < 0 || px.y() < 0 || px.x() > camera.width - 1 || px.y() > camera.height - 1) {
          continue;
        }
        t.obs.push_back({k, px});
      }
      if (t.obs.size() >= 3) {
        tracks.push_back(t);
        truth.point_world.push_back(x);
        sways.push_back(moves);
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

// The rounds as tracking runs them, with the rig's camera or the calibration given.
SparseMap Adjusted(const SyntheticRig& rig, const BundleOptions& o,
                   const std::optional<PinholeCamera>& calibration = std::nullopt) {
  const PinholeCamera& camera = calibration ? *calibration : rig.camera;
  SparseMap map;
  PlaceOnCircle(rig.phi, 1.0, &map);
  for (int round = 0; round < 3; ++round) {
    TriangulateTracks(o, rig.tracks, camera, &map);
    RunBundleAdjustment(o, rig.tracks, camera, &map);
  }
  return map;
}

// Max distance (m) of the map's camera centres from the truth's.
double WorstCentreErrorM(const SyntheticRig& rig, const SparseMap& map) {
  double worst = 0.0;
  for (size_t k = 0; k < rig.phi.size(); ++k) {
    worst = std::max(worst, (map.centre_world[k] - rig.truth.centre_world[k]).norm());
  }
  return worst;
}

// Focus breathing of `pct` %: a focal length that follows the scene all round the turn, and one
// focused far (shorter) but for two short arcs where a near trunk fills the middle of the view.
std::function<double(double)> Wavering(double pct) {
  return [pct](double phi) { return 1.0 + 0.01 * pct * std::sin(5.0 * phi + std::cos(3.0 * phi)); };
}
std::function<double(double)> NearTrunkNowAndThen(double pct) {
  return [pct](double phi) {
    const double a = std::remainder(phi, 2.0 * M_PI);
    const bool near = std::abs(a - 1.0) < 0.25 || std::abs(a + 2.0) < 0.2;
    return 1.0 + 0.01 * pct * (near ? 1.0 : -1.0);
  };
}

// One more round with a focal length per keyframe, as tracking runs it.
void AdjustPerKeyframe(const SyntheticRig& rig, const BundleOptions& o, SparseMap* map) {
  map->keyframe_focal_scale.assign(rig.phi.size(), 1.0);
  TriangulateTracks(o, rig.tracks, rig.camera, map);
  RunBundleAdjustment(o, rig.tracks, rig.camera, map);
}

// A breathing focal length that one shared focal length cannot follow is taken up by the camera
// centres, moved in and out by centimetres (a zoom of the near scene looks like a step towards
// it); a focal length per keyframe takes it back, and the centres come out as a fixed-focus
// camera's do.
TEST(BundleAdjustment, AFocalLengthPerKeyframeFollowsABreathingFocus) {
  BundleOptions o;
  o.max_points = 2000;
  o.refine_focal = true;
  for (const auto& [seed, pattern] :
       {std::pair{12, Wavering(0.7)}, std::pair{13, NearTrunkNowAndThen(0.7)}}) {
    const SyntheticRig rig(seed, pattern);
    SparseMap map = Adjusted(rig, o);
    EXPECT_GT(WorstCentreErrorM(rig, map), 0.02) << seed;
    AdjustPerKeyframe(rig, o, &map);
    EXPECT_LT(WorstCentreErrorM(rig, map), 0.006) << seed;  // metres, as without breathing
    double worst_scale = 0.0;
    for (size_t k = 0; k < rig.phi.size(); ++k) {
      worst_scale = std::max(worst_scale, std::abs(map.FocalScaleAt(static_cast<int>(k)) -
                                                   rig.truth.keyframe_focal_scale[k]));
    }
    EXPECT_LT(worst_scale, 0.002) << seed;  // against the 0.7 % breathing
  }
}

// The refined focal lengths stray from their median as the truth's do where the focus breathes,
// and by a few hundredths of a percent where it does not: what tells tracking to keep them.
TEST(BundleAdjustment, KeyframeFocalLengthsStrayOnlyWhereTheFocusBreathes) {
  BundleOptions o;
  o.max_points = 2000;
  o.refine_focal = true;
  const TrackOptions track;
  const SyntheticRig fixed_focus(11);
  SparseMap map = Adjusted(fixed_focus, o);
  AdjustPerKeyframe(fixed_focus, o, &map);
  EXPECT_EQ(BreathingKeyframes(track, map.keyframe_focal_scale), 0);
  const std::vector<double> fixed_stray = FocalScaleStrayPct(map.keyframe_focal_scale);
  EXPECT_LT(*std::max_element(fixed_stray.begin(), fixed_stray.end()),
            0.5 * track.breathing_min_pct);
  for (const auto& pattern : {Wavering(0.7), NearTrunkNowAndThen(0.5)}) {
    const SyntheticRig rig(11, pattern);
    map = Adjusted(rig, o);
    AdjustPerKeyframe(rig, o, &map);
    // Up to a couple that lie within the estimates' noise of the threshold.
    EXPECT_NEAR(BreathingKeyframes(track, map.keyframe_focal_scale),
                BreathingKeyframes(track, rig.truth.keyframe_focal_scale), 2);
    EXPECT_GE(BreathingKeyframes(track, map.keyframe_focal_scale), track.breathing_min_keyframes);
  }
}

// A 100° lens whose calibration is off only near the picture's side edges (0.08° there, 0.005°
// at 0.83 of the way out), as `calibrate --lens wide` made it of a simulated board video: points
// enter and leave the view at those edges, and the refined focal length follows them. Left out
// where the lens squeezes the picture below min_lens_scale, they no longer pull it.
TEST(BundleAdjustment, TheFocalLengthIsNotPulledByTheLeastSureEdgesOfAWideLens) {
  const PinholeCamera lens = PinholeCamera::FromLensHfov(640, 360, 100.0, -0.25, 0.07, -0.008);
  const SyntheticRig rig(14, nullptr, lens);
  PinholeCamera calibration = lens;
  calibration.k1 = -0.25035;
  calibration.k2 = 0.07121;
  calibration.k3 = -0.00915;
  BundleOptions o;
  o.max_points = 2000;
  o.refine_focal = true;
  EXPECT_NEAR(LensRadialScale(lens, {lens.cx, lens.cy}), 1.0, 1e-9);
  EXPECT_LT(LensRadialScale(lens, {639.0, lens.cy}), o.min_lens_scale);
  const double with_edges = std::abs(Adjusted(
                                         rig,
                                         [&] {
                                           BundleOptions all = o;
                                           all.min_lens_scale = 0.0;
                                           return all;
                                         }(),
                                         calibration)
                                         .focal_scale -
                                     1.0);
  const double without = std::abs(Adjusted(rig, o, calibration).focal_scale - 1.0);
  EXPECT_GT(with_edges, 0.002);
  EXPECT_LT(without, 0.5 * with_edges);
  EXPECT_LT(without, 0.001);
}

// Leaves that flutter by about a pixel either way stay under the outlier threshold in most
// keyframes, so their observations stay; their tracks' rms error gives them away, and they go
// whole while the still points stay.
TEST(BundleAdjustment, DropsTheTracksOfPointsThatMove) {
  RigSway flutter;
  flutter.amplitude_m = 0.008;  // 0.6 px at 7 m (f 484 px), 0.4 px at 10 m
  flutter.min_r_m = 6.0;
  flutter.max_r_m = 10.0;
  flutter.top_m = 0.5;
  const SyntheticRig rig(21, nullptr, PinholeCamera::FromHfov(640, 360, 67.0), flutter);
  BundleOptions o;
  o.max_points = 3000;
  o.refine_focal = true;
  std::vector<int> moving_kept, still_kept;
  for (double max_track_rms_px : {0.0, o.max_track_rms_px}) {
    BundleOptions later_rounds = o;
    later_rounds.max_track_rms_px = max_track_rms_px;
    SparseMap map;
    PlaceOnCircle(rig.phi, 1.0, &map);
    for (int round = 0; round < 3; ++round) {
      TriangulateTracks(o, rig.tracks, rig.camera, &map);
      RunBundleAdjustment(round == 0 ? o : later_rounds, rig.tracks, rig.camera, &map);
    }
    moving_kept.push_back(0);
    still_kept.push_back(0);
    for (size_t t = 0; t < rig.tracks.size(); ++t) {
      (rig.sways[t] ? moving_kept : still_kept).back() += map.point_valid[t] ? 1 : 0;
    }
  }
  const int moving = static_cast<int>(std::count(rig.sways.begin(), rig.sways.end(), 1));
  const int still = static_cast<int>(rig.tracks.size()) - moving;
  ASSERT_GT(moving, 300);
  EXPECT_GT(moving_kept[0], moving / 4);  // the outlier threshold alone keeps many
  EXPECT_LT(moving_kept[1], moving_kept[0] / 2);
  for (int kept : still_kept) EXPECT_GT(kept, 0.995 * still);
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
  for (double sigma_pct : {0.0, -1.0, 11.0, std::numeric_limits<double>::quiet_NaN()}) {
    BundleOptions t;
    t.sigma_keyframe_focal_pct = sigma_pct;
    EXPECT_THROW(t.Check(), InputError) << sigma_pct;
  }
  for (double scale : {-0.1, 1.0, std::numeric_limits<double>::quiet_NaN()}) {
    BundleOptions t;
    t.min_lens_scale = scale;
    EXPECT_THROW(t.Check(), InputError) << scale;
  }
  for (double rms_px : {-0.1, std::numeric_limits<double>::quiet_NaN()}) {
    BundleOptions t;
    t.max_track_rms_px = rms_px;
    EXPECT_THROW(t.Check(), InputError) << rms_px;
  }
  BundleOptions no_iterations;
  no_iterations.max_iterations = 0;
  EXPECT_THROW(no_iterations.Check(), InputError);
}

}  // namespace
}  // namespace stemmap::track
