#include "stemmap/calib/calibrate.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/rng.h"
#include "stemmap/video/video_writer.h"

namespace stemmap::calib {
namespace {

namespace fs = std::filesystem;

// A video of a 9x6 board seen by a known camera from varied poses.
void WriteBoardVideo(const fs::path& path, const PinholeCamera& cam, int frames) {
  const int sq = 60, margin = 60;
  cv::Mat board(7 * sq + 2 * margin, 10 * sq + 2 * margin, CV_8UC1, cv::Scalar(255));
  for (int r = 0; r < 7; ++r) {
    for (int c = 0; c < 10; ++c) {
      if ((r + c) % 2 == 0) {
        board(cv::Rect(margin + c * sq, margin + r * sq, sq, sq)).setTo(cv::Scalar(0));
      }
    }
  }
  // Board pixels to metres on the board plane, the first inner corner at the origin.
  const double px_per_m = sq / 0.025, off = margin + sq - 0.5;
  cv::Matx33d plane_from_board(1 / px_per_m, 0, -off / px_per_m, 0, 1 / px_per_m, -off / px_per_m,
                               0, 0, 1);
  cv::Matx33d k(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  VideoWriterOptions wo;
  wo.width = cam.width;
  wo.height = cam.height;
  wo.fps = 10;
  wo.bitrate_mbps = 8;
  VideoWriter writer(path, wo);
  Rng rng(11);
  for (int i = 0; i < frames; ++i) {
    cv::Vec3d rvec(rng.Uniform(-0.5, 0.5), rng.Uniform(-0.5, 0.5), rng.Uniform(-0.3, 0.3));
    cv::Matx33d r;
    cv::Rodrigues(rvec, r);
    // Board centre (0.1, 0.0625 m from the first corner) placed ahead of the camera.
    const cv::Vec3d centre(0.1, 0.0625, 0.0);
    const cv::Vec3d t =
        cv::Vec3d(rng.Uniform(-0.05, 0.05), rng.Uniform(-0.03, 0.03), rng.Uniform(0.45, 0.65)) -
        r * centre;
    const cv::Matx33d rt(r(0, 0), r(0, 1), t[0], r(1, 0), r(1, 1), t[1], r(2, 0), r(2, 1), t[2]);
    const cv::Matx33d h = k * rt * plane_from_board;
    cv::Mat gray, bgr;
    cv::warpPerspective(board, gray, cv::Mat(h), cv::Size(cam.width, cam.height), cv::INTER_AREA,
                        cv::BORDER_CONSTANT, cv::Scalar(120));
    cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
    writer.Write(bgr);
  }
  writer.Close();
}

TEST(Calibrate, RecoversAKnownCamera) {
  const fs::path dir = fs::temp_directory_path() / ("stemmap_calib_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  PinholeCamera truth = PinholeCamera::FromHfov(640, 360, 65.0);
  truth.cx += 4.0;
  WriteBoardVideo(dir / "board.mp4", truth, 30);
  CalibrateOptions o;
  o.scan_frames = 30;
  o.max_views = 25;
  const CalibrateSummary s = RunCalibrate(o, dir / "board.mp4", dir / "calibration.yaml");
  EXPECT_GE(s.views, 20);
  EXPECT_LT(s.rms_px, 0.5);
  EXPECT_NEAR(s.camera.fx / truth.fx, 1.0, 0.01);
  EXPECT_NEAR(s.camera.cx, truth.cx, 3.0);
  EXPECT_NEAR(s.camera.cy, truth.cy, 3.0);
  // The file is what `track --calibration` reads, at any working size.
  const PinholeCamera half = ReadCalibration(dir / "calibration.yaml", 320, 180);
  EXPECT_NEAR(half.fx, s.camera.fx / 2, 1e-6);
  EXPECT_THROW(ReadCalibration(dir / "calibration.yaml", 360, 640), InputError);
  fs::remove_all(dir);
}

TEST(Calibrate, NoBoardIsAnError) {
  const fs::path dir = fs::temp_directory_path() / ("stemmap_calib0_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  VideoWriterOptions wo;
  wo.width = 320;
  wo.height = 180;
  wo.fps = 10;
  {
    VideoWriter w(dir / "empty.mp4", wo);
    for (int i = 0; i < 20; ++i) w.Write(cv::Mat(180, 320, CV_8UC3, cv::Scalar(90, 120, 60)));
    w.Close();
  }
  CalibrateOptions o;
  EXPECT_THROW(RunCalibrate(o, dir / "empty.mp4", dir / "c.yaml"), InputError);
  EXPECT_FALSE(fs::exists(dir / "c.yaml"));
  fs::remove_all(dir);
}

// Damaged calibration files are refused with our error, never an OpenCV exception or a huge
// allocation (the first case is a fuzzer's finding: "rows:&3" read as an enormous size).
TEST(Calibrate, DamagedCalibrationFilesAreInputErrors) {
  const fs::path dir = fs::temp_directory_path() / ("stemmap_calib1_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string head = "%YAML:1.0\n---\nimage_width: 1920\nimage_height: 1080\n";
  const std::string matrix =
      "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
      "   data: [ 1500., 0., 959.5, 0., 1500., 539.5, 0., 0., 1. ]\n";
  std::vector<std::string> damaged = {
      head +
          "camera_matrix: !!opencv-matrix\n   rows:&3\n   cols: 3\n   dt: d\n"
          "   data: [ 1500., 0., 959.5, 0.,(1500., 539.5, 0., 0., 1. ]\n",
      head +
          "camera_matrix: !!opencv-matrix\n   rows: 300000\n   cols: 300000\n   dt: d\n"
          "   data: [ 1. ]\n",
      head + "camera_matrix: a string\n",
      head + matrix + "distortion_coefficients: [ 1, 2\n",
      "%YAML:1.0\n---\n" + matrix,
      head +
          "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
          "   data: [ -1500., 0., 959.5, 0., 1500., 539.5, 0., 0., 1. ]\n",
      "\xff\xfe binary",
      // A fuzzer's finding: OpenCV's parser threw std::length_error on this damaged key.
      head + matrix +
          "distort/ocients: !!opencv-matrix\n   rows: 1\n   : 3\n   dt: d\n"
          "   data: [ 1500., 0., 9591, 0., 0., 0. \x88]\n",
  };
  // A fuzzer's finding: OpenCV's parser looped forever on this (NUL bytes in a YAML header).
  damaged.push_back(
      std::string("%YAML:1.0 1080\n-------\0\0\0\0ML:1.0 1080\n-----open_coeffL:\n", 46));
  // And on this (a second "%YAML" directive and "---" separator).
  damaged.push_back(
      "%YAML:1.0 1080\n-----------@------%YAML:1.0\n-------\nimage_widthage_heigh-222t");
  for (size_t i = 0; i < damaged.size(); ++i) {
    const fs::path path = dir / ("damaged" + std::to_string(i) + ".yaml");
    WriteFileAtomic(path, damaged[i]);
    EXPECT_THROW(ReadCalibration(path, 1920, 1080), InputError) << damaged[i];
  }
  WriteFileAtomic(dir / "good.yaml", head + matrix);
  EXPECT_NEAR(ReadCalibration(dir / "good.yaml", 1920, 1080).fx, 1500.0, 1e-9);
  fs::remove_all(dir);
}

// OpenCV's five coefficients are k1 k2 p1 p2 k3: the fifth is read as k3, and a lens whose
// distortion folds over inside the image is refused.
TEST(Calibrate, ReadsK3AndRefusesAFoldingLens) {
  const fs::path dir = fs::temp_directory_path() / ("stemmap_calib2_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string head = "%YAML:1.0\n---\nimage_width: 1920\nimage_height: 1080\n";
  const std::string matrix =
      "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
      "   data: [ 1055., 0., 959.5, 0., 1055., 539.5, 0., 0., 1. ]\n";
  const auto distortion = [](const std::string& data) {
    return "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n"
           "   data: [ " +
           data + " ]\n";
  };
  WriteFileAtomic(dir / "wide.yaml", head + matrix + distortion("-0.25, 0.07, 0., 0., -0.008"));
  const PinholeCamera wide = ReadCalibration(dir / "wide.yaml", 960, 540);
  EXPECT_EQ(wide.k1, -0.25);
  EXPECT_EQ(wide.k2, 0.07);
  EXPECT_EQ(wide.k3, -0.008);
  EXPECT_NEAR(wide.fx, 527.5, 1e-9);
  WriteFileAtomic(dir / "fold.yaml", head + matrix + distortion("-0.25, 0., 0., 0., 0."));
  EXPECT_THROW(ReadCalibration(dir / "fold.yaml", 1920, 1080), InputError);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace stemmap::calib
