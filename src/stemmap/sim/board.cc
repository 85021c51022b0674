#include "stemmap/sim/board.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "stemmap/core/error.h"
#include "stemmap/video/video_writer.h"

namespace stemmap::sim {

void BoardVideoOptions::Check() const {
  if (inner_cols < 3 || inner_rows < 3) {
    throw InputError(
        fmt::format("board {}x{}: at least 3x3 inner corners", inner_cols, inner_rows));
  }
  if (!(square_m > 0.0 && square_m < 0.2)) throw InputError("board square must be in (0, 0.2) m");
  if (views < 5) throw InputError("a board video needs at least 5 views");
  if (!(fps > 0.0 && fps <= 60.0)) throw InputError("board video fps must be in (0, 60]");
  if (!(min_width_share > 0.05 && max_width_share >= min_width_share && max_width_share <= 1.0)) {
    throw InputError("the board's share of the image width must satisfy 0.05 < min <= max <= 1");
  }
  if (!(max_tilt_deg >= 0.0 && max_tilt_deg < 80.0)) throw InputError("board tilt in [0, 80)°");
  if (supersample < 1 || supersample > 8) throw InputError("board supersampling in [1, 8]");
  if (!(noise_grey >= 0.0)) throw InputError("board noise must not be negative");
}

namespace {

constexpr double kDeg = M_PI / 180.0;

// The board's printed area in its own frame (metres): the squares reach one square beyond the
// outer inner corners, and a white margin one square wide surrounds them.
struct BoardLayout {
  double sq, x_lo, x_hi, y_lo, y_hi;
  explicit BoardLayout(const BoardVideoOptions& o)
      : sq(o.square_m),
        x_lo(-2 * o.square_m),
        x_hi((o.inner_cols + 1) * o.square_m),
        y_lo(-2 * o.square_m),
        y_hi((o.inner_rows + 1) * o.square_m) {}
  Eigen::Vector3d Centre() const { return {0.5 * (x_lo + x_hi), 0.5 * (y_lo + y_hi), 0.0}; }
  // Grey level of the print at (x, y): black and white squares, the white margin, or -1 off it.
  double Print(double x, double y) const {
    if (x < x_lo || x > x_hi || y < y_lo || y > y_hi) return -1.0;
    if (x < x_lo + sq || x > x_hi - sq || y < y_lo + sq || y > y_hi - sq) return 255.0;
    const int ix = static_cast<int>(std::floor(x / sq)), iy = static_cast<int>(std::floor(y / sq));
    return ((ix + iy) % 2 + 2) % 2 == 0 ? 0.0 : 255.0;
  }
};

// Whether all of the board, margin included, lies inside the image (a margin of 2 % of the
// width) and within the lens's field.
bool WholeBoardInView(const BoardLayout& b, const PinholeCamera& cam,
                      const Rigid3d& cam_from_board) {
  const double margin = 0.02 * cam.width;
  for (double x : {b.x_lo, b.x_hi}) {
    for (double y : {b.y_lo, b.y_hi}) {
      const Eigen::Vector3d p = cam_from_board * Eigen::Vector3d(x, y, 0.0);
      if (p.z() < 0.05) return false;
      // Beyond the lens's field the distortion polynomial folds back: a point there would
      // appear inside the image. Compare the ray with the one its pixel gives back.
      const Eigen::Vector2d px = cam.ImageFromCam(p);
      if (px.x() < margin || px.y() < margin || px.x() > cam.width - 1 - margin ||
          px.y() > cam.height - 1 - margin) {
        return false;
      }
      const Eigen::Vector3d back = cam.CamRayFromImage(px);
      if ((back.head<2>() - p.head<2>() / p.z()).norm() > 1e-3) return false;
    }
  }
  return true;
}

}  // namespace

Rigid3d BoardPose(const BoardVideoOptions& o, const PinholeCamera& cam, int i, Rng* rng) {
  const BoardLayout b(o);
  // A 4 x 3 grid of aims over the image, each visited in turn, jittered.
  constexpr int kCols = 4, kRows = 3;
  const int cell = i % (kCols * kRows);
  const Eigen::Vector2d centre_px(cam.cx, cam.cy);
  const Eigen::Vector2d aim_px(
      cam.width * (0.04 + 0.92 * ((cell % kCols) + rng->Uniform(0.2, 0.8)) / kCols),
      cam.height * (0.04 + 0.92 * ((cell / kCols) + rng->Uniform(0.2, 0.8)) / kRows));
  const double diagonal_m = std::hypot(b.x_hi - b.x_lo, b.y_hi - b.y_lo);
  const double width_m_at_1m = cam.width / cam.fx;  // the pinhole part's field
  double distance_m =
      diagonal_m / (rng->Uniform(o.min_width_share, o.max_width_share) * width_m_at_1m);
  const double tilt = rng->Uniform(0.0, o.max_tilt_deg) * kDeg;
  const double tilt_axis = rng->Uniform(0.0, 2 * M_PI);
  const double roll = rng->Uniform(-30.0, 30.0) * kDeg;
  Rigid3d cam_from_board;
  // Toward the image's centre in tenths of the way, then farther off, until all of it shows.
  for (int attempt = 0; attempt < 60; ++attempt) {
    const double toward_centre = 0.1 * (attempt % 11);
    if (attempt > 0 && attempt % 11 == 0) distance_m *= 1.15;
    const Eigen::Vector2d px = aim_px + toward_centre * (centre_px - aim_px);
    const Eigen::Vector3d dir = cam.CamRayFromImage(px).normalized();
    // The board faces the camera (its z axis along the line of sight, away from the camera),
    // then turns by `tilt` about an axis across the line of sight and by `roll` about its normal.
    const Eigen::Quaterniond facing =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), dir);
    const Eigen::Vector3d across =
        facing * Eigen::Vector3d(std::cos(tilt_axis), std::sin(tilt_axis), 0.0);
    const Eigen::Quaterniond rotation = Eigen::AngleAxisd(tilt, across) * facing *
                                        Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ());
    cam_from_board.rotation = rotation.normalized();
    cam_from_board.translation = distance_m * dir - cam_from_board.rotation * b.Centre();
    if (WholeBoardInView(b, cam, cam_from_board)) break;
  }
  return cam_from_board;
}

namespace {

// The unit-z ray through every sub-pixel sample, row by row (the lens's inverse is a Newton
// iteration per ray: computed once for all the views).
std::vector<Eigen::Vector3f> SampleRays(int supersample, const PinholeCamera& cam) {
  const int s = supersample;
  std::vector<Eigen::Vector3f> rays(static_cast<size_t>(cam.width) * cam.height * s * s);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < cam.height; ++v) {
    size_t i = static_cast<size_t>(v) * cam.width * s * s;
    for (int u = 0; u < cam.width; ++u) {
      for (int a = 0; a < s; ++a) {
        for (int c = 0; c < s; ++c) {
          const Eigen::Vector2d px(u + (c + 0.5) / s - 0.5, v + (a + 0.5) / s - 0.5);
          rays[i++] = cam.CamRayFromImage(px).cast<float>();
        }
      }
    }
  }
  return rays;
}

cv::Mat RenderBoardWithRays(const BoardVideoOptions& o, const PinholeCamera& cam,
                            const std::vector<Eigen::Vector3f>& rays, const Rigid3d& cam_from_board,
                            Rng* rng) {
  const BoardLayout b(o);
  const Rigid3d board_from_cam = cam_from_board.Inverse();
  const Eigen::Matrix3d rotation = board_from_cam.rotation.toRotationMatrix();
  const Eigen::Vector3d origin = board_from_cam.translation;
  const int n = o.supersample * o.supersample;
  cv::Mat mean(cam.height, cam.width, CV_64F);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const size_t first = (static_cast<size_t>(v) * cam.width + u) * n;
      double sum = 0.0;
      for (int k = 0; k < n; ++k) {
        const Eigen::Vector3d dir = rotation * rays[first + k].cast<double>();
        double grey = -1.0;
        if (std::abs(dir.z()) > 1e-12) {
          const double t = -origin.z() / dir.z();
          if (t > 0) grey = b.Print(origin.x() + t * dir.x(), origin.y() + t * dir.y());
        }
        sum += grey < 0 ? 120.0 : grey;  // a mid-grey wall behind the board
      }
      mean.at<double>(v, u) = sum / n;
    }
  }
  // The noise in pixel order on one thread: the same seed gives the same video.
  cv::Mat out(cam.height, cam.width, CV_8UC1);
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      out.at<uchar>(v, u) =
          cv::saturate_cast<uchar>(mean.at<double>(v, u) + rng->Normal(0.0, o.noise_grey));
    }
  }
  return out;
}

}  // namespace

cv::Mat RenderBoard(const BoardVideoOptions& o, const PinholeCamera& cam,
                    const Rigid3d& cam_from_board, Rng* rng) {
  return RenderBoardWithRays(o, cam, SampleRays(o.supersample, cam), cam_from_board, rng);
}

void WriteBoardVideo(const BoardVideoOptions& o, const PinholeCamera& cam, uint64_t seed,
                     double bitrate_mbps, const std::filesystem::path& video) {
  o.Check();
  cam.Check();
  Rng rng(HashCombine(seed, 0xB0A2D));
  VideoWriterOptions wo;
  wo.width = cam.width;
  wo.height = cam.height;
  wo.fps = o.fps;
  wo.bitrate_mbps = bitrate_mbps;
  wo.gop_frames = 1;  // every pose a key frame: the poses do not follow from one another
  VideoWriter writer(video, wo);
  const std::vector<Eigen::Vector3f> rays = SampleRays(o.supersample, cam);
  for (int i = 0; i < o.views; ++i) {
    const Rigid3d pose = BoardPose(o, cam, i, &rng);
    cv::Mat bgr;
    cv::cvtColor(RenderBoardWithRays(o, cam, rays, pose, &rng), bgr, cv::COLOR_GRAY2BGR);
    writer.Write(bgr);
  }
  writer.Close();
}

}  // namespace stemmap::sim
