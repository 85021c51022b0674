#include "stemmap/track/keyframe_zoom.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace stemmap::track {
namespace {

// Centroid (px) of a picture's brightness.
Eigen::Vector2d Centroid(const cv::Mat& gray) {
  const cv::Moments m = cv::moments(gray);
  return {m.m10 / m.m00, m.m01 / m.m00};
}

// A soft spot where a camera of focal scale `s` images what the camera itself shows at `at`.
cv::Mat SpotTakenAtScale(const PinholeCamera& camera, const Eigen::Vector2d& at, double s) {
  cv::Mat img(camera.height, camera.width, CV_32F, cv::Scalar(0));
  const Eigen::Vector2d c(camera.cx, camera.cy);
  const Eigen::Vector2d p = c + s * (at - c);
  for (int y = 0; y < img.rows; ++y) {
    for (int x = 0; x < img.cols; ++x) {
      const double d2 = (Eigen::Vector2d(x, y) - p).squaredNorm();
      img.at<float>(y, x) = static_cast<float>(std::exp(-d2 / (2 * 3.0 * 3.0)));
    }
  }
  return img;
}

TEST(UndoFocalScale, PutsWhatALongerOrShorterFocalLengthShowedWhereTheCameraShowsIt) {
  PinholeCamera camera = PinholeCamera::FromHfov(320, 180, 67.0);
  camera.k1 = -0.1;  // the redraw does not depend on the lens
  for (double s : {0.99, 0.993, 1.007, 1.01}) {
    for (const Eigen::Vector2d& at :
         {Eigen::Vector2d(30, 40), Eigen::Vector2d(290, 150), Eigen::Vector2d(160, 90)}) {
      const cv::Mat taken = SpotTakenAtScale(camera, at, s);
      const Eigen::Vector2d moved = Centroid(taken);
      const Eigen::Vector2d redrawn = Centroid(UndoFocalScale(taken, camera, s));
      EXPECT_LT((redrawn - at).norm(), 0.05) << s << " " << at.transpose();
      if ((at - Eigen::Vector2d(camera.cx, camera.cy)).norm() > 100) {
        EXPECT_GT((moved - at).norm(), 0.5);  // the breathing moved it that far
      }
    }
  }
}

TEST(UndoFocalScale, LeavesAPictureAtTheCamerasFocalLengthAlone) {
  const PinholeCamera camera = PinholeCamera::FromHfov(64, 36, 67.0);
  cv::Mat img(36, 64, CV_8UC3, cv::Scalar(10, 20, 30));
  const cv::Mat same = UndoFocalScale(img, camera, 1.0);
  EXPECT_EQ(same.data, img.data);
}

}  // namespace
}  // namespace stemmap::track
