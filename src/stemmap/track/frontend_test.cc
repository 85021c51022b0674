#include "stemmap/track/frontend.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "stemmap/core/error.h"
#include "stemmap/video/video_reader.h"
#include "stemmap/video/video_writer.h"

namespace stemmap::track {
namespace {

TEST(Frontend, OptionsRejectKltWindowsTooSmall) {
  EXPECT_NO_THROW(FrontendOptions{}.Check());
  FrontendOptions tiny;
  tiny.lk_refine_window_px = 1;
  try {
    tiny.Check();
    FAIL() << "a 1-px refinement window was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("KLT windows"), std::string::npos) << e.what();
  }
  FrontendOptions levels;
  levels.lk_refine_levels = -1;
  EXPECT_THROW(levels.Check(), InputError);
}

// A rolling shutter: the top row is read half a readout before the frame's time, the bottom row
// half after, the middle row at it; a point moves back along its velocity by that much.
TEST(Frontend, AtFrameTimeUndoesEachRowsDelay) {
  const Eigen::Vector2d v(-300.0, 20.0);  // px/s: a turning camera
  const double readout_s = 0.025;
  const int rows = 541;
  EXPECT_EQ(AtFrameTime({100.0, 270.0}, v, readout_s, rows), Eigen::Vector2d(100.0, 270.0));
  const Eigen::Vector2d top = AtFrameTime({100.0, 0.0}, v, readout_s, rows);
  EXPECT_NEAR(top.x(), 100.0 - 0.5 * readout_s * 300.0, 1e-12);
  EXPECT_NEAR(top.y(), 0.0 + 0.5 * readout_s * 20.0, 1e-12);
  const Eigen::Vector2d bottom = AtFrameTime({100.0, 540.0}, v, readout_s, rows);
  EXPECT_NEAR(bottom.x(), 100.0 + 0.5 * readout_s * 300.0, 1e-12);
  // A global shutter moves nothing.
  EXPECT_EQ(AtFrameTime({100.0, 0.0}, v, 0.0, rows), Eigen::Vector2d(100.0, 0.0));
  FrontendOptions o;
  o.readout_ms = -1;
  EXPECT_THROW(o.Check(), InputError);
  o.readout_ms = 150;
  EXPECT_THROW(o.Check(), InputError);
}

// A camera panning across a wall of textured vertical bars (trunks), as a short clip.
// A new folder for this test's files, removed by the test.
std::filesystem::path ScratchDir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("stemmap_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

// The test clips' format: 320×240 at 15 fps.
VideoWriterOptions QvgaAt15Fps() {
  VideoWriterOptions wo;
  wo.width = 320;
  wo.height = 240;
  wo.fps = 15;
  return wo;
}

std::filesystem::path PanningClip(const std::filesystem::path& dir) {
  cv::RNG rng(7);
  cv::Mat wall(360, 2400, CV_8UC3);
  rng.fill(wall, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(wall, wall, cv::Size(3, 3), 0.8);
  for (int x = 40; x < wall.cols - 60; x += 90) {
    cv::rectangle(wall, cv::Rect(x, 0, 30, wall.rows), cv::Scalar(30, 40, 45), cv::FILLED);
  }
  const VideoWriterOptions wo = QvgaAt15Fps();
  const std::filesystem::path path = dir / "pan.mp4";
  VideoWriter writer(path, wo);
  for (int i = 0; i < 60; ++i) writer.Write(wall(cv::Rect(20 + 12 * i, 60, 320, 240)).clone());
  writer.Close();
  return path;
}

// ORB features and vertical segments are found for every keyframe off the tracking thread; a
// keyframe's features are those of its own picture, whatever the timing, and two runs agree.
TEST(Frontend, EveryKeyframeGetsItsOwnFeatures) {
  const std::filesystem::path dir = ScratchDir("frontend");
  const std::filesystem::path clip = PanningClip(dir);
  FrontendOptions o;
  o.working_long_side_px = 320;
  o.orb_features = 200;
  const PinholeCamera camera = PinholeCamera::FromHfov(320, 240, 60.0);
  auto run = [&] {
    VideoReaderOptions ro;
    ro.max_long_side_px = 320;
    ro.prefetch_frames = 4;
    VideoReader reader(clip, ro);
    return RunFrontend(o, reader, camera);
  };
  const FrontendResult a = run(), b = run();
  ASSERT_GE(a.keyframes.size(), 5u);
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  cv::Ptr<cv::ORB> orb = cv::ORB::create(o.orb_features);
  for (size_t i = 0; i < a.keyframes.size(); ++i) {
    SCOPED_TRACE(i);
    const Keyframe& kf = a.keyframes[i];
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    orb->detectAndCompute(kf.gray, cv::noArray(), keypoints, descriptors);
    ASSERT_FALSE(keypoints.empty());
    ASSERT_EQ(kf.orb_keypoints.size(), keypoints.size());
    EXPECT_EQ(cv::norm(kf.orb_descriptors, descriptors, cv::NORM_HAMMING), 0.0);
    EXPECT_EQ(cv::norm(kf.orb_descriptors, b.keyframes[i].orb_descriptors, cv::NORM_HAMMING), 0.0);
    // The bars' edges, near vertical and the height of the picture.
    EXPECT_GE(kf.vertical_segments.size(), 4u);
    ASSERT_EQ(kf.vertical_segments.size(), b.keyframes[i].vertical_segments.size());
    for (size_t s = 0; s < kf.vertical_segments.size(); ++s) {
      EXPECT_EQ(kf.vertical_segments[s], b.keyframes[i].vertical_segments[s]);
    }
  }
  std::filesystem::remove_all(dir);
}

// A panning clip read by a rolling shutter (row v at t + readout (v / (rows - 1) - 1/2)) whose
// top rows show a near wall that moves `near_px_s` and the rest a far wall that moves `far_px_s`,
// both leftwards: every point at the frame's time lies on a line in time.
std::filesystem::path RollingShutterClip(const std::filesystem::path& dir, double readout_s,
                                         int near_rows, double near_px_s, double far_px_s) {
  cv::RNG rng(11);
  cv::Mat near_wall(240, 3000, CV_8UC3), far_wall(240, 3000, CV_8UC3);
  for (cv::Mat* wall : {&near_wall, &far_wall}) {
    rng.fill(*wall, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(*wall, *wall, cv::Size(5, 5), 1.2);
  }
  const VideoWriterOptions wo = QvgaAt15Fps();
  const std::filesystem::path path = dir / "rolling.mp4";
  VideoWriter writer(path, wo);
  for (int i = 0; i < 30; ++i) {
    cv::Mat frame(240, 320, CV_8UC3);
    for (int v = 0; v < frame.rows; ++v) {
      const double t_s = i / wo.fps + readout_s * (v / (frame.rows - 1.0) - 0.5);
      const bool near = v < near_rows;
      const double left = 20.0 + (near ? near_px_s : far_px_s) * t_s;
      cv::Mat row;
      cv::getRectSubPix(near ? near_wall : far_wall, cv::Size(320, 1),
                        cv::Point2f(static_cast<float>(left + 159.5), static_cast<float>(v)), row);
      row.copyTo(frame.row(v));
    }
    writer.Write(frame);
  }
  writer.Close();
  return path;
}

// Under a rolling shutter each observation is moved to its frame's time with its own point's
// velocity: a point born at a keyframe in a part of the picture that moves faster than most (a
// near stem) too, though its velocity is known only once it has been followed a step.
TEST(Frontend, ObservationsAtTheFrameTimeLieOnTheirTracksLine) {
  const std::filesystem::path dir = ScratchDir("rolling");
  const double readout_s = 0.06, near_px_s = 300.0, far_px_s = 120.0;
  const int near_rows = 80;
  const std::filesystem::path clip =
      RollingShutterClip(dir, readout_s, near_rows, near_px_s, far_px_s);
  FrontendOptions o;
  o.working_long_side_px = 320;
  o.readout_ms = 1e3 * readout_s;
  VideoReaderOptions ro;
  ro.max_long_side_px = 320;
  VideoReader reader(clip, ro);
  const FrontendResult r = RunFrontend(o, reader, PinholeCamera::FromHfov(320, 240, 60.0));
  int near_first = 0;
  for (const Track& t : r.tracks) {
    const Observation& first = t.obs.front();
    // Top rows, away from where the walls meet: the near wall; read 30 ms early.
    if (first.px.y() > near_rows - 20 || t.obs.size() < 2) continue;
    ++near_first;
    for (const Observation& ob : t.obs) {
      const double dt_s = r.keyframes[ob.keyframe].t_s - r.keyframes[first.keyframe].t_s;
      const Eigen::Vector2d& last = t.obs.back().px;
      const double last_dt_s =
          r.keyframes[t.obs.back().keyframe].t_s - r.keyframes[first.keyframe].t_s;
      // The line through the last observation at the wall's speed.
      EXPECT_NEAR(ob.px.x(), last.x() + near_px_s * (last_dt_s - dt_s), 0.5)
          << "keyframe " << ob.keyframe << " of a track born at " << first.keyframe;
    }
  }
  EXPECT_GE(near_first, 10);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace stemmap::track
