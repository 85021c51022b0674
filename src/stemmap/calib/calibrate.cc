#include "stemmap/calib/calibrate.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <charconv>
#include <cmath>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/persistence.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string_view>

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

LensKind ParseLensKind(const std::string& name) {
  if (name == "main") return LensKind::kMain;
  if (name == "wide") return LensKind::kWide;
  throw InputError(fmt::format("unknown lens '{}': use main or wide", name));
}

std::string ToString(LensKind lens) { return lens == LensKind::kWide ? "wide" : "main"; }

std::string CalibrateSummary::BriefReport() const {
  const std::string k3 = camera.k3 != 0.0 ? fmt::format(" k3 {:+.4f}", camera.k3) : "";
  return fmt::format(
      "{}x{}, fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f} k1 {:+.4f} k2 {:+.4f}{} "
      "(hfov {:.1f}°), {} views, rms {:.3f} px",
      camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy, camera.k1, camera.k2,
      k3, camera.HfovDeg(), views, rms_px);
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
  // k3 stays 0 for a main camera (LensKind). A file written elsewhere may carry one (d[4]).
  const int k3_flag = o.lens == LensKind::kWide ? 0 : cv::CALIB_FIX_K3;
  const double rms = cv::calibrateCamera(object_points, used, size, k, d, rvecs, tvecs,
                                         k3_flag | cv::CALIB_ZERO_TANGENT_DIST);
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
  s.camera.k3 = d.at<double>(4);
  s.camera.Check();

  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  fs << "image_width" << size.width << "image_height" << size.height << "camera_matrix" << k
     << "distortion_coefficients" << d << "rms_px" << rms << "views" << s.views;
  WriteFileAtomic(out_yaml, fs.releaseAndGetString());
  return s;
}

namespace {

// The fields of a calibration file: top-level "key: value" lines, and a matrix's "rows", "cols",
// "dt" and "data: [ ... ]" (the list may run over several lines) indented below its key.
struct CalibrationFields {
  std::map<std::string, std::string> scalars;                        // top-level key -> value
  std::map<std::string, std::map<std::string, std::string>> nested;  // key -> field -> value
};

std::string Trim(std::string_view s) {
  const size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return "";
  const size_t e = s.find_last_not_of(" \t\r");
  return std::string(s.substr(b, e - b + 1));
}

CalibrationFields ParseCalibrationText(const std::string& text, const std::string& shown) {
  CalibrationFields f;
  std::istringstream in(text);
  std::string line, current, *open_list = nullptr;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (open_list) {  // inside a "data: [" list until its "]"
      *open_list += " " + Trim(line);
      if (line.find(']') != std::string::npos) open_list = nullptr;
      continue;
    }
    const std::string t = Trim(line.substr(0, line.find('#')));
    if (t.empty() || t[0] == '%' || t == "---") continue;
    const size_t colon = t.find(':');
    if (colon == std::string::npos || colon == 0) {
      throw InputError(fmt::format("calibration {}:{}: expected \"key: value\"", shown, line_no));
    }
    const std::string key = Trim(t.substr(0, colon)), value = Trim(t.substr(colon + 1));
    const bool top_level = line[0] != ' ' && line[0] != '\t';
    if (top_level) current = key;
    if (!top_level && current.empty()) {
      throw InputError(
          fmt::format("calibration {}:{}: indented line outside a field", shown, line_no));
    }
    std::string& slot = top_level ? f.scalars[key] : f.nested[current][key];
    slot = value;
    if (!value.empty() && value[0] == '[' && value.find(']') == std::string::npos) {
      open_list = &slot;
    }
  }
  if (open_list) throw InputError(fmt::format("calibration {}: a list is not closed", shown));
  return f;
}

double ParseNumber(const std::string& s, const std::string& what) {
  double v = 0.0;
  const char* end = s.data() + s.size();
  const auto [ptr, ec] = std::from_chars(s.data(), end, v);
  if (ec != std::errc() || ptr != end || !std::isfinite(v)) {
    throw InputError(fmt::format("{}: '{}' is not a number", what, s));
  }
  return v;
}

int ParseInt(const std::string& s, const std::string& what) {
  const double v = ParseNumber(s, what);
  if (v != std::floor(v) || std::abs(v) > 1e6) {
    throw InputError(fmt::format("{}: '{}' is not a whole number", what, s));
  }
  return static_cast<int>(v);
}

// A matrix field as a list of rows x cols numbers (empty when the field is absent).
std::vector<double> ReadMatrix(const CalibrationFields& f, const std::string& key,
                               const std::string& shown) {
  const auto it = f.nested.find(key);
  const std::string what = fmt::format("calibration {}: {}", shown, key);
  if (it == f.nested.end()) {
    const auto scalar = f.scalars.find(key);
    if (scalar != f.scalars.end() && !scalar->second.empty() &&
        scalar->second != "!!opencv-matrix") {
      throw InputError(fmt::format("{} must be a matrix (rows, cols, data)", what));
    }
    return {};
  }
  const auto field = [&](const char* name) {
    const auto v = it->second.find(name);
    if (v == it->second.end()) throw InputError(fmt::format("{} has no {}", what, name));
    return v->second;
  };
  const int rows = ParseInt(field("rows"), what), cols = ParseInt(field("cols"), what);
  std::string data = field("data");
  if (data.size() < 2 || data.front() != '[' || data.back() != ']') {
    throw InputError(fmt::format("{}: data must be a list [ ... ]", what));
  }
  std::vector<double> values;
  std::istringstream items(data.substr(1, data.size() - 2));
  for (std::string item; std::getline(items, item, ',');) {
    if (!Trim(item).empty()) values.push_back(ParseNumber(Trim(item), what));
  }
  if (rows < 1 || cols < 1 || static_cast<size_t>(rows) * cols != values.size()) {
    throw InputError(
        fmt::format("{}: {}x{} does not match its {} numbers", what, rows, cols, values.size()));
  }
  return values;
}

}  // namespace

// Read with a parser of our own: OpenCV's (4.6) loops forever or throws the standard library's
// errors on some damaged files (a fuzzer's findings), and the files are a small fixed layout,
// the one OpenCV writes and ROS's camera_info shares.
PinholeCamera ReadCalibration(const std::filesystem::path& path, int width, int height) {
  const std::string text = ReadFileToString(path);
  const std::string shown = path.string();
  constexpr size_t kMaxCalibrationBytes = 1 << 20;
  if (text.size() > kMaxCalibrationBytes || text.find('\0') != std::string::npos) {
    throw InputError(fmt::format("calibration {} is not a YAML text file", shown));
  }
  const CalibrationFields f = ParseCalibrationText(text, shown);
  const auto size = [&](const char* key) {
    const auto it = f.scalars.find(key);
    return it == f.scalars.end() ? 0 : ParseInt(it->second, "calibration " + shown + ": " + key);
  };
  const int cw = size("image_width"), ch = size("image_height");
  const std::vector<double> k = ReadMatrix(f, "camera_matrix", shown);
  const std::vector<double> d = ReadMatrix(f, "distortion_coefficients", shown);
  if (k.size() != 9 || cw <= 0 || ch <= 0) {
    throw InputError(fmt::format(
        "calibration {} needs camera_matrix (3x3), image_width and image_height", shown));
  }
  PinholeCamera c;
  c.width = cw;
  c.height = ch;
  c.fx = k[0];
  c.fy = k[4];
  c.cx = k[2];
  c.cy = k[5];
  if (!d.empty()) c.k1 = d[0];
  if (d.size() > 1) c.k2 = d[1];
  // OpenCV's order is k1 k2 p1 p2 k3; the tangential p1, p2 are not modelled.
  if (d.size() > 4) c.k3 = d[4];
  c.Check();
  if (std::abs(static_cast<double>(cw) / ch - static_cast<double>(width) / height) > 0.01) {
    throw InputError(fmt::format("calibration {} is for {}x{}, the video is {}x{} (another shape)",
                                 shown, cw, ch, width, height));
  }
  return c.Scaled(static_cast<double>(width) / cw);
}

}  // namespace stemmap::calib
