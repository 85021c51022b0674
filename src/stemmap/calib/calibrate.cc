#include "stemmap/calib/calibrate.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgproc.hpp>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/progress.h"
#include "stemmap/video/video_reader.h"

namespace stemmap::calib {

void CalibrateOptions::Check() const {
  if (inner_cols < 3 || inner_rows < 3) {
    throw InputError(
        fmt::format("board {}x{} inner corners: at least 3x3 needed", inner_cols, inner_rows));
  }
  if (!(square_m > 0)) throw InputError("--square must be positive");
  if (max_views < 5) throw InputError("--max-views must be at least 5");
  if (scan_frames < max_views) throw InputError("scan frames must be at least max views");
}

std::string CalibrateSummary::BriefReport() const {
  return fmt::format(
      "{}x{}, fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f} k1 {:+.4f} k2 {:+.4f} "
      "(hfov {:.1f}°), {} views, rms {:.3f} px",
      camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy, camera.k1, camera.k2,
      camera.HfovDeg(), views, rms_px);
}

CalibrateSummary RunCalibrate(const CalibrateOptions& o, const std::filesystem::path& video,
                              const std::filesystem::path& out_yaml) {
  o.Check();
  VideoReader reader(video);
  const VideoInfo info = reader.info();
  const int64_t total = std::max<int64_t>(1, info.frame_count);
  const int64_t step = std::max<int64_t>(1, total / o.scan_frames);
  const cv::Size pattern(o.inner_cols, o.inner_rows);
  std::vector<std::vector<cv::Point2f>> image_points;
  cv::Size size;
  Progress progress("calibrate", total);
  while (std::optional<DecodedFrame> f = reader.Next()) {
    progress.Update(f->index + 1);
    if (f->index % step != 0) continue;
    cv::Mat gray;
    cv::cvtColor(f->bgr, gray, cv::COLOR_BGR2GRAY);
    size = gray.size();
    // Search a smaller copy (fast), refine the corners at full resolution.
    const double s = std::min(1.0, 960.0 / std::max(gray.cols, gray.rows));
    cv::Mat small;
    cv::resize(gray, small, cv::Size(), s, s, cv::INTER_AREA);
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(small, pattern, corners,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE |
                                       cv::CALIB_CB_FAST_CHECK)) {
      continue;
    }
    for (cv::Point2f& c : corners) c = (c + cv::Point2f(0.5f, 0.5f)) / s - cv::Point2f(0.5f, 0.5f);
    cv::cornerSubPix(gray, corners, cv::Size(7, 7), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 40, 0.01));
    image_points.push_back(std::move(corners));
  }
  progress.Finish();
  if (static_cast<int>(image_points.size()) < 8) {
    throw InputError(fmt::format(
        "the {}x{} board was found in only {} frames of {} (8 needed): check --board and that "
        "the whole board is in view and sharp",
        o.inner_cols, o.inner_rows, image_points.size(), video.string()));
  }
  // Spread the views used over the detections.
  std::vector<std::vector<cv::Point2f>> used;
  const double stride = std::max(1.0, static_cast<double>(image_points.size()) / o.max_views);
  for (double i = 0; i < image_points.size() && static_cast<int>(used.size()) < o.max_views;
       i += stride) {
    used.push_back(image_points[static_cast<size_t>(i)]);
  }
  std::vector<cv::Point3f> board;
  for (int r = 0; r < o.inner_rows; ++r) {
    for (int c = 0; c < o.inner_cols; ++c) {
      board.emplace_back(static_cast<float>(c * o.square_m), static_cast<float>(r * o.square_m),
                         0.f);
    }
  }
  std::vector<std::vector<cv::Point3f>> object_points(used.size(), board);
  cv::Mat k = cv::Mat::eye(3, 3, CV_64F), d = cv::Mat::zeros(5, 1, CV_64F);
  std::vector<cv::Mat> rvecs, tvecs;
  const double rms = cv::calibrateCamera(object_points, used, size, k, d, rvecs, tvecs,
                                         cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST);
  CalibrateSummary s;
  s.views = static_cast<int>(used.size());
  s.rms_px = rms;
  s.camera.width = size.width;
  s.camera.height = size.height;
  s.camera.fx = k.at<double>(0, 0);
  s.camera.fy = k.at<double>(1, 1);
  s.camera.cx = k.at<double>(0, 2);
  s.camera.cy = k.at<double>(1, 2);
  s.camera.k1 = d.at<double>(0);
  s.camera.k2 = d.at<double>(1);
  s.camera.Check();

  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  fs << "image_width" << size.width << "image_height" << size.height << "camera_matrix" << k
     << "distortion_coefficients" << d << "rms_px" << rms << "views" << s.views;
  WriteFileAtomic(out_yaml, fs.releaseAndGetString());
  return s;
}

PinholeCamera ReadCalibration(const std::filesystem::path& path, int width, int height) {
  cv::FileStorage fs;
  try {
    fs.open(path.string(), cv::FileStorage::READ);
  } catch (const cv::Exception& e) {
    throw InputError(fmt::format("cannot read calibration {}: {}", path.string(), e.msg));
  }
  if (!fs.isOpened()) throw InputError(fmt::format("cannot open calibration {}", path.string()));
  cv::Mat k, d;
  int cw = 0, ch = 0;
  fs["camera_matrix"] >> k;
  fs["distortion_coefficients"] >> d;
  fs["image_width"] >> cw;
  fs["image_height"] >> ch;
  if (k.rows != 3 || k.cols != 3 || cw <= 0 || ch <= 0) {
    throw InputError(fmt::format(
        "calibration {} needs camera_matrix (3x3), image_width and image_height", path.string()));
  }
  k.convertTo(k, CV_64F);
  PinholeCamera c;
  c.width = cw;
  c.height = ch;
  c.fx = k.at<double>(0, 0);
  c.fy = k.at<double>(1, 1);
  c.cx = k.at<double>(0, 2);
  c.cy = k.at<double>(1, 2);
  if (!d.empty()) {
    d.convertTo(d, CV_64F);
    d = d.reshape(1, static_cast<int>(d.total()));
    c.k1 = d.at<double>(0);
    if (d.total() > 1) c.k2 = d.at<double>(1);
  }
  c.Check();
  if (std::abs(static_cast<double>(cw) / ch - static_cast<double>(width) / height) > 0.01) {
    throw InputError(fmt::format("calibration {} is for {}x{}, the video is {}x{} (another shape)",
                                 path.string(), cw, ch, width, height));
  }
  return c.Scaled(static_cast<double>(width) / cw);
}

}  // namespace stemmap::calib
