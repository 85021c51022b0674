#include "stemmap/track/video_checks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "stemmap/core/error.h"

namespace stemmap::track {
namespace {

// A front end's result for a `seconds`-long video at 10 fps, tracked at 960x540, whose picture
// moved by the given totals.
FrontendResult Seen(double seconds, double sideways_px, double vertical_px) {
  FrontendResult f;
  f.working_size = cv::Size(960, 540);
  for (double t = 0; t <= seconds + 1e-9; t += 0.1) f.frame_t_s.push_back(t);
  f.info.duration_s = seconds;
  f.info.fps = 10;
  f.sideways_motion_px = sideways_px;
  f.vertical_motion_px = vertical_px;
  return f;
}

TEST(VideoChecks, FramesTooSmallToMeasureTrunksAreRefused) {
  VideoInfo info;
  info.full_width = 160;
  info.full_height = 90;
  EXPECT_THROW(CheckFrameSize(info), InputError);
  info.full_width = 180;  // portrait 180x320 is enough
  info.full_height = 320;
  EXPECT_NO_THROW(CheckFrameSize(info));
}

TEST(VideoChecks, MotionTellsATurnFromAStillCameraAndATurnedPicture) {
  const PinholeCamera camera = PinholeCamera::FromHfov(960, 540, 65.0);
  // A turn and a bit: 400° at 65° a frame width.
  EXPECT_EQ(MotionProblem(Seen(45, 400.0 / 65.0 * 960, 300), camera), "");
  EXPECT_NE(MotionProblem(Seen(45, 30, 20), camera).find("does not turn"), std::string::npos);
  EXPECT_NE(MotionProblem(Seen(45, 900, 5000), camera).find("turned 90°"), std::string::npos);
}

TEST(VideoChecks, ACutShortCopyAndDamagedDataAreNamed) {
  FrontendResult f = Seen(10, 0, 0);
  EXPECT_EQ(DamageNote(f), "");
  f.info.duration_s = 45;
  EXPECT_TRUE(EndsEarly(f));
  EXPECT_NE(DamageNote(f).find("frames up to 10.0 s of the 45.0 s"), std::string::npos);
  f.info.duration_s = 10.5;  // within a second of the header: whole
  EXPECT_FALSE(EndsEarly(f));
  f.damaged_frames = 4;
  f.damaged_spans_s = {{3.0, 3.4}};
  EXPECT_NE(DamageNote(f).find("4 frames could not be decoded whole, at 3.0-3.4 s"),
            std::string::npos);
}

// A gap in the tracks where frames were damaged is bridged at the turn rate either side; one
// where nothing was damaged (tracking lost for another reason), or too long, is not.
TEST(VideoChecks, OnlyShortDamagedGapsAreBridged) {
  FrontendResult f = Seen(10, 0, 0);
  const double rate = 0.15;  // rad/s
  std::vector<double> inc;
  for (int k = 0; k < 20; ++k) {
    f.keyframes.emplace_back().t_s = 0.5 * k;
    inc.push_back(k == 0 ? 0.0 : rate * 0.5);
  }
  f.keyframes[10].t_s = 6.0;  // the frames 4.5-6.0 s are missing
  for (int k = 11; k < 20; ++k) f.keyframes[k].t_s = 6.0 + 0.5 * (k - 10);
  inc[10] = std::nan("");
  std::vector<double> lost_elsewhere = inc;
  f.damaged_spans_s = {{4.6, 5.9}};
  const auto bridged = BridgeDamagedGaps(f, 3.0, &inc);
  ASSERT_EQ(bridged.size(), 1u);
  EXPECT_DOUBLE_EQ(bridged[0].first, 4.5);
  EXPECT_NEAR(inc[10], rate * 1.5, 1e-12);
  EXPECT_TRUE(BridgeDamagedGaps(f, 1.0, &lost_elsewhere).empty()) << "longer than allowed";
  f.damaged_spans_s = {{8.0, 8.2}};
  EXPECT_TRUE(BridgeDamagedGaps(f, 3.0, &lost_elsewhere).empty()) << "no damage in the gap";
  EXPECT_TRUE(std::isnan(lost_elsewhere[10]));
}

}  // namespace
}  // namespace stemmap::track
