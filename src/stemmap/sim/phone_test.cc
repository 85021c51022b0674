#include "stemmap/sim/phone.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <tuple>

#include "stemmap/core/error.h"
#include "stemmap/sim/render.h"
#include "stemmap/sim/simulate.h"

namespace stemmap::sim {
namespace {

TEST(Phone, PresetsFillTheirValues) {
  SimulateOptions o;
  o.hfov_deg = 66.0;
  ApplyPhonePreset(PhonePreset::kMain, &o);
  EXPECT_EQ(o.phone.preset, PhonePreset::kMain);
  EXPECT_EQ(o.phone.readout_ms, 25.0);
  EXPECT_EQ(o.k1, 0.02);
  EXPECT_EQ(o.k2, -0.01);
  EXPECT_EQ(o.k3, 0.0);
  EXPECT_EQ(o.phone.breathing_pct, 0.7);
  EXPECT_GT(o.phone.wind, 0.0);
  EXPECT_FALSE(o.phone.stabilisation);
  EXPECT_EQ(o.hfov_deg, 0.0);  // drawn from the seed, as for any phone
  ApplyPhonePreset(PhonePreset::kWide, &o);
  EXPECT_EQ(o.hfov_deg, 100.0);
  EXPECT_EQ(o.k1, -0.25);
  EXPECT_EQ(o.k2, 0.07);
  EXPECT_EQ(o.k3, -0.008);
  EXPECT_EQ(o.phone.readout_ms, 30.0);
  EXPECT_GT(o.phone.breathing_pct, 0.0);
  EXPECT_LT(o.phone.breathing_pct, 0.7);
  EXPECT_GT(o.phone.wind, 0.0);
  o.out_dir = "unused";
  EXPECT_NO_THROW(o.Check());
  // The wide lens really spans 100° without folding over.
  const PinholeCamera wide = PinholeCamera::FromLensHfov(1920, 1080, 100.0, o.k1, o.k2, o.k3);
  EXPECT_NEAR(wide.LensHfovDeg(), 100.0, 1e-9);
  EXPECT_NO_THROW(wide.Check());
  ApplyPhonePreset(PhonePreset::kIdeal, &o);
  EXPECT_FALSE(o.phone.Any());
  EXPECT_EQ(o.k1, 0.0);
  EXPECT_EQ(o.hfov_deg, 0.0);
  // Saved with the preset's name, read back whole.
  ApplyPhonePreset(PhonePreset::kMain, &o);
  const nlohmann::json j = o.phone;
  EXPECT_EQ(j.at("preset"), "main");
  const PhoneOptions back = j.get<PhoneOptions>();
  EXPECT_EQ(back.preset, PhonePreset::kMain);
  EXPECT_EQ(back.readout_ms, 25.0);
  EXPECT_EQ(ParsePhonePreset("wide"), PhonePreset::kWide);
  EXPECT_THROW(ParsePhonePreset("tele"), InputError);
  // An options file's unknown preset is an error, not the ideal camera.
  nlohmann::json tele = j;
  tele["preset"] = "tele";
  EXPECT_THROW((void)tele.get<PhoneOptions>(), InputError);
}

TEST(Phone, ChecksRefuseImplausibleEffects) {
  SimulateOptions o;
  o.out_dir = "unused";
  o.phone.readout_ms = 40.0;  // longer than a frame at 30 fps
  EXPECT_THROW(o.Check(), InputError);
  o.fps = 15.0;
  EXPECT_NO_THROW(o.Check());
  o.phone.wind = 1.5;
  EXPECT_THROW(o.Check(), InputError);
  o.phone.wind = 0.5;
  o.phone.breathing_pct = -1.0;
  EXPECT_THROW(o.Check(), InputError);
  o.phone.breathing_pct = 0.7;
  o.phone.stabilisation_crop = 0.9;
  EXPECT_THROW(o.Check(), InputError);
  o.phone.stabilisation_crop = 1.1;
  // A lens that folds over inside a 100° image.
  o.hfov_deg = 100.0;
  o.k1 = -0.25;
  EXPECT_THROW(o.Check(), InputError);
  o.k2 = 0.07;
  o.k3 = -0.008;
  EXPECT_NO_THROW(o.Check());
}

TEST(Phone, BreathingFollowsTheFocusDistance) {
  EXPECT_NEAR(BreathingScale(1.0, 0.7), 1.007, 1e-12);
  EXPECT_NEAR(BreathingScale(0.4, 0.7), 1.007, 1e-12);
  EXPECT_NEAR(BreathingScale(10.0, 0.7), 0.993, 1e-12);
  EXPECT_NEAR(BreathingScale(1e4, 0.7), 0.993, 1e-12);
  EXPECT_EQ(BreathingScale(3.0, 0.0), 1.0);
  double previous = 2.0;
  for (double d = 0.5; d < 20.0; d *= 1.2) {
    const double s = BreathingScale(d, 0.7);
    EXPECT_LE(s, previous);  // nearer focus, longer focal length
    previous = s;
  }
  // The autofocus lags: after one time constant 63 % of a step in dioptres is done.
  Autofocus af(0.3, 10.0);
  for (int i = 0; i < 30; ++i) af.Update(2.0, 0.01);
  EXPECT_NEAR(1.0 / af.focus_m(), 0.1 + (0.5 - 0.1) * (1.0 - std::exp(-1.0)), 1e-9);
}

// What the autofocus meters: a stem 1.3 m ahead is near (the focal length grows), the view past
// it far (the focal length shrinks).
TEST(Phone, CentreDepthDrivesBreathingTheRightWay) {
  SceneOptions so;
  so.layout = {{1.3, 0.0, 30.0}};
  so.keep_clear_m = 1.0;
  so.seed = 5;
  Scene scene = GenerateScene(so);
  scene.trees.erase(scene.trees.begin() + 1, scene.trees.end());
  scene.shrubs.clear();
  const PinholeCamera cam = PinholeCamera::FromHfov(160, 90, 60.0);
  const Renderer renderer(scene, cam, RenderOptions{});
  Eigen::Matrix3d r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  FrameSetup at_stem;
  at_stem.world_from_cam = {Eigen::Quaterniond(r), {0, 0, 1.3}};
  FrameSetup past_it = at_stem;
  past_it.world_from_cam.rotation =
      Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitZ()) * at_stem.world_from_cam.rotation;
  const double near_m = renderer.CentreDepth(at_stem);
  const double far_m = renderer.CentreDepth(past_it);
  EXPECT_NEAR(near_m, 1.3 - 0.15, 0.1);
  EXPECT_GT(far_m, 4.0);
  EXPECT_GT(BreathingScale(near_m, 0.7), 1.0);
  EXPECT_LT(BreathingScale(far_m, 0.7), BreathingScale(near_m, 0.7));
}

// The stabilising crop: its shifts average out over a clip, and they put a direction of the
// smoothed camera where the smoothed camera would see it, whatever the jitter.
TEST(Phone, StabilisationCancelsTheJitter) {
  RigParams rig;
  rig.seconds = 20.0;
  rig.fps = 30.0;
  rig.seed = 4;
  rig.wobble_deg = 0.5;
  const std::vector<RigFrame> frames = SimulateRig(rig);
  const double window_s = 0.5;
  const std::vector<Eigen::Vector2d> jitter = RotationJitter(frames, rig.fps, window_s);
  ASSERT_EQ(jitter.size(), frames.size());
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  double sq = 0.0;
  for (const Eigen::Vector2d& j : jitter) {
    mean += j / jitter.size();
    sq += j.squaredNorm() / jitter.size();
  }
  const double rms = std::sqrt(sq);
  EXPECT_GT(rms, 0.05 * 0.5 * std::numbers::pi / 180.0);  // the wobble is there
  EXPECT_LT(mean.norm(), 0.2 * rms);                      // and the shifts are centred on zero

  const PinholeCamera nominal = PinholeCamera::FromHfov(960, 540, 65.0);
  const int half = static_cast<int>(std::lround(0.5 * window_s * rig.fps));
  double err_stabilised = 0.0, err_plain = 0.0;
  int n = 0;
  for (int i = half; i + half < static_cast<int>(frames.size()); ++i) {
    // The smoothed rotation: the centred window's mean.
    Eigen::Vector4d sum = Eigen::Vector4d::Zero();
    const Eigen::Quaterniond& q_i = frames[i].world_from_cam.rotation;
    for (int j = i - half; j <= i + half; ++j) {
      const Eigen::Quaterniond& q = frames[j].world_from_cam.rotation;
      sum += (q.coeffs().dot(q_i.coeffs()) < 0 ? -1.0 : 1.0) * q.coeffs();
    }
    const Eigen::Quaterniond smooth = Eigen::Quaterniond(sum).normalized();
    // A distant point the smoothed camera sees near the image centre.
    const Eigen::Vector2d target(nominal.cx + 12.0, nominal.cy - 7.0);
    const Eigen::Vector3d dir_world = smooth * nominal.CamRayFromImage(target);
    const Eigen::Vector3d dir_cam = q_i.conjugate() * dir_world;
    const PinholeCamera stabilised = FrameCamera(nominal, 1.0, jitter[i], 1.1);
    err_stabilised += (stabilised.ImageFromCam(dir_cam) - target).squaredNorm();
    err_plain += (nominal.ImageFromCam(dir_cam) - target).squaredNorm();
    ++n;
  }
  err_stabilised = std::sqrt(err_stabilised / n);
  err_plain = std::sqrt(err_plain / n);
  EXPECT_GT(err_plain, 1.0);                   // px the wobble shakes the image by
  EXPECT_LT(err_stabilised, 0.1 * err_plain);  // what the crop leaves of it (the roll)
}

// The rig between frames: at a frame's time the frame's pose, and between two frames (or half a
// frame beyond the clip's ends) no farther from either than they are from each other.
TEST(Phone, RigPoseBetweenFramesIsContinuous) {
  RigParams rig;
  rig.seconds = 4.0;
  rig.seed = 8;
  const RigMotion motion(rig);
  const std::vector<RigFrame> frames = motion.Frames();
  for (size_t i = 0; i < frames.size(); i += 7) {
    const Rigid3d pose = motion.WorldFromCam(frames[i].t_s);
    EXPECT_LT((pose.translation - frames[i].world_from_cam.translation).norm(), 1e-9);
    EXPECT_LT(pose.rotation.angularDistance(frames[i].world_from_cam.rotation), 1e-9);
  }
  const double dt = 0.5 / rig.fps;
  const size_t last = frames.size() - 1;
  for (const auto& [t, a, b] : {std::tuple{-dt, size_t{0}, size_t{1}},
                                std::tuple{frames[10].t_s + dt, size_t{10}, size_t{11}},
                                std::tuple{frames[last].t_s + dt, last - 1, last}}) {
    const Rigid3d pose = motion.WorldFromCam(t);
    const Rigid3d& pa = frames[a].world_from_cam;
    const Rigid3d& pb = frames[b].world_from_cam;
    const double turn = pa.rotation.angularDistance(pb.rotation);
    const double step = (pa.translation - pb.translation).norm();
    for (const Rigid3d* p : {&pa, &pb}) {
      EXPECT_LT(pose.rotation.angularDistance(p->rotation), 1.6 * turn) << t;
      EXPECT_LT((pose.translation - p->translation).norm(), 1.6 * step) << t;
      EXPECT_GT(pose.rotation.angularDistance(p->rotation), 0.2 * turn) << t;
    }
  }
}

}  // namespace
}  // namespace stemmap::sim
