#include "stemmap/dense/stereo.h"

#include <fmt/format.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "stemmap/core/error.h"

namespace stemmap::dense {

void StereoOptions::Check() const {
  if (!(scale > 0.1 && scale <= 1.0)) throw InputError("stereo scale must lie in (0.1, 1]");
  if (num_disparities < 16 || num_disparities % 16 != 0) {
    throw InputError(
        fmt::format("disparities {} must be a positive multiple of 16", num_disparities));
  }
  if (block_size < 3 || block_size % 2 == 0)
    throw InputError("stereo block size must be odd, >= 3");
  if (!(min_depth_m > 0 && max_depth_m > min_depth_m)) throw InputError("bad stereo depth range");
  if (pixel_step < 1) throw InputError("pixel step must be at least 1");
  if (!(view_bottom_share >= 0 && view_bottom_share < 1)) {
    throw InputError("the share of the view's bottom edge must lie in [0, 1)");
  }
}

std::vector<CloudPoint> StereoPairPoints(const StereoOptions& o, const cv::Mat& bgr_a,
                                         const cv::Mat& bgr_b, const PinholeCamera& cam_full,
                                         const Rigid3d& world_from_a, const Rigid3d& world_from_b,
                                         int keyframe_a, double beyond_max_depth_m,
                                         std::vector<CloudPoint>* beyond) {
  const PinholeCamera cam = cam_full.Scaled(o.scale);
  const cv::Size size(cam.width, cam.height);
  cv::Mat small_a, small_b;
  cv::resize(bgr_a, small_a, size, 0, 0, cv::INTER_AREA);
  cv::resize(bgr_b, small_b, size, 0, 0, cv::INTER_AREA);
  // SGBM wants the left camera first: the one further along -x of the other.
  const Eigen::Vector3d b_in_a = world_from_a.Inverse() * world_from_b.translation;
  const bool a_is_left = b_in_a.x() > 0;
  const Rigid3d& world_from_left = a_is_left ? world_from_a : world_from_b;
  const Rigid3d& world_from_right = a_is_left ? world_from_b : world_from_a;
  const cv::Mat& img_left = a_is_left ? small_a : small_b;
  const cv::Mat& img_right = a_is_left ? small_b : small_a;
  const Rigid3d right_from_left = world_from_right.Inverse() * world_from_left;

  cv::Matx33d k(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  cv::Mat d = (cv::Mat_<double>(1, 5) << cam.k1, cam.k2, 0, 0, cam.k3);
  cv::Mat r, t;
  cv::eigen2cv(Eigen::Matrix3d(right_from_left.rotation.toRotationMatrix()), r);
  cv::eigen2cv(Eigen::Vector3d(right_from_left.translation), t);
  cv::Mat r1, r2, p1, p2, q;
  cv::stereoRectify(k, d, k, d, size, r, t, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, 0.0);
  cv::Mat m1x, m1y, m2x, m2y, rect_left, rect_right, gray_left, gray_right;
  cv::initUndistortRectifyMap(k, d, r1, p1, size, CV_32FC1, m1x, m1y);
  cv::initUndistortRectifyMap(k, d, r2, p2, size, CV_32FC1, m2x, m2y);
  cv::remap(img_left, rect_left, m1x, m1y, cv::INTER_LINEAR);
  cv::remap(img_right, rect_right, m2x, m2y, cv::INTER_LINEAR);
  cv::cvtColor(rect_left, gray_left, cv::COLOR_BGR2GRAY);
  cv::cvtColor(rect_right, gray_right, cv::COLOR_BGR2GRAY);

  cv::Ptr<cv::StereoSGBM> sgbm =
      cv::StereoSGBM::create(0, o.num_disparities, o.block_size, 8 * o.block_size * o.block_size,
                             32 * o.block_size * o.block_size, 1, 0, o.uniqueness_ratio,
                             o.speckle_window, o.speckle_range, cv::StereoSGBM::MODE_SGBM_3WAY);
  cv::Mat disp16, disp;
  sgbm->compute(gray_left, gray_right, disp16);
  disp16.convertTo(disp, CV_32F, 1.0 / 16.0);
  cv::Mat xyz;
  cv::reprojectImageTo3D(disp, xyz, q, true);

  Eigen::Matrix3d r1e;
  cv::cv2eigen(r1, r1e);
  const Eigen::Matrix3d left_from_rect = r1e.transpose();
  const Eigen::Vector3f origin = world_from_left.translation.cast<float>();
  // The lowest matched row of each column: the bottom edge of what the pair saw there.
  std::vector<int> lowest_row(static_cast<size_t>(disp.cols), -1);
  for (int y = 0; y < disp.rows; ++y) {
    const float* dp = disp.ptr<float>(y);
    for (int x = 0; x < disp.cols; ++x) {
      if (dp[x] > 0.5f) lowest_row[x] = y;
    }
  }
  const int bottom_rows = static_cast<int>(std::lround(o.view_bottom_share * disp.rows));
  std::vector<CloudPoint> out;
  for (int y = 0; y < xyz.rows; y += o.pixel_step) {
    const float* dp = disp.ptr<float>(y);
    const cv::Vec3f* pp = xyz.ptr<cv::Vec3f>(y);
    const cv::Vec3b* cp = rect_left.ptr<cv::Vec3b>(y);
    for (int x = 0; x < xyz.cols; x += o.pixel_step) {
      if (!(dp[x] > 0.5f)) continue;
      const Eigen::Vector3d p_rect(pp[x][0], pp[x][1], pp[x][2]);
      if (!(p_rect.z() > o.min_depth_m)) continue;
      std::vector<CloudPoint>* to = &out;
      if (!(p_rect.z() < o.max_depth_m)) {
        if (beyond == nullptr || !(p_rect.z() < beyond_max_depth_m)) continue;
        to = beyond;
      }
      const Eigen::Vector3d p_world = world_from_left * (left_from_rect * p_rect);
      to->push_back(
          {p_world.cast<float>(), origin, cp[x], keyframe_a, -1, y >= lowest_row[x] - bottom_rows});
    }
  }
  return out;
}

}  // namespace stemmap::dense
