#include "stemmap/dense/stereo.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"

namespace stemmap::dense {
namespace {

// A textured wall `depth_m` in front of a camera at `centre` (world axes = camera axes), with
// its texture fixed to the wall: what that camera images.
cv::Mat ImageOfWall(const PinholeCamera& cam, const cv::Mat& texture, double texels_per_m,
                    double depth_m, const Eigen::Vector3d& centre) {
  cv::Mat map_x(cam.height, cam.width, CV_32F), map_y(cam.height, cam.width, CV_32F);
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const double t = depth_m - centre.z();
      const double x = centre.x() + t * (u - cam.cx) / cam.fx;
      const double y = centre.y() + t * (v - cam.cy) / cam.fy;
      map_x.at<float>(v, u) = static_cast<float>(texture.cols / 2 + x * texels_per_m);
      map_y.at<float>(v, u) = static_cast<float>(texture.rows / 2 + y * texels_per_m);
    }
  }
  cv::Mat image;
  cv::remap(texture, image, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return image;
}

// The points a pair marks at its view's bottom are the lowest it matched in each column of its
// view: a textured wall filling the frame is matched down to the last rows, and only there.
TEST(StereoPairPoints, MarksTheBottomEdgeOfWhatThePairSaw) {
  Rng rng(5);
  cv::Mat noise(600, 600, CV_8UC3);
  for (int y = 0; y < noise.rows; ++y) {
    for (int x = 0; x < noise.cols; ++x) {
      noise.at<cv::Vec3b>(y, x) = cv::Vec3b(static_cast<uint8_t>(rng.Uniform(0, 255)),
                                            static_cast<uint8_t>(rng.Uniform(0, 255)),
                                            static_cast<uint8_t>(rng.Uniform(0, 255)));
    }
  }
  cv::Mat texture;
  cv::GaussianBlur(noise, texture, cv::Size(3, 3), 0.8);
  const PinholeCamera cam = PinholeCamera::FromHfov(320, 180, 60.0);
  Rigid3d world_from_a, world_from_b;
  world_from_b.translation = Eigen::Vector3d(0.15, 0, 0);
  const double depth_m = 3.0;
  const cv::Mat a = ImageOfWall(cam, texture, 120.0, depth_m, world_from_a.translation);
  const cv::Mat b = ImageOfWall(cam, texture, 120.0, depth_m, world_from_b.translation);
  StereoOptions o;
  o.scale = 1.0;
  o.pixel_step = 1;
  const std::vector<CloudPoint> pts = StereoPairPoints(o, a, b, cam, world_from_a, world_from_b, 3);
  ASSERT_GT(pts.size(), 10000u);
  // Each point's column and row in image a; the lowest row matched in each column.
  std::map<int, double> lowest;
  std::vector<std::pair<int, double>> at;
  for (const CloudPoint& p : pts) {
    const Eigen::Vector2d uv = cam.ImageFromCam(p.world.cast<double>());
    at.emplace_back(static_cast<int>(std::lround(uv.x())), uv.y());
    lowest[at.back().first] = std::max(lowest[at.back().first], uv.y());
  }
  int marked = 0, marked_low = 0;
  const double band_px = o.view_bottom_share * cam.height;
  for (size_t i = 0; i < pts.size(); ++i) {
    EXPECT_EQ(pts[i].keyframe, 3);
    EXPECT_NEAR(pts[i].world.z(), depth_m, 0.1);
    const double above_px = lowest[at[i].first] - at[i].second;
    if (pts[i].at_view_bottom) {
      ++marked;
      EXPECT_LT(above_px, band_px + 2.0) << "marked, yet " << above_px << " px above the bottom";
      marked_low += at[i].second > 0.85 * cam.height;
    } else {
      EXPECT_GT(above_px, band_px - 2.0) << "unmarked, " << above_px << " px above the bottom";
    }
  }
  // About a band of view_bottom_share of the rows over the columns matched, at the frame's
  // bottom but in the odd column the matcher left nearly empty.
  EXPECT_GT(marked_low, 0.95 * marked);
  EXPECT_GT(marked, static_cast<int>(0.5 * band_px * lowest.size()));
  EXPECT_LT(marked, static_cast<int>(2.0 * (band_px + 1) * lowest.size()));
}

TEST(StereoOptions, AViewBottomShareOutsideZeroToOneIsRefused) {
  StereoOptions o;
  o.view_bottom_share = 1.0;
  EXPECT_THROW(o.Check(), InputError);
  o.view_bottom_share = -0.01;
  EXPECT_THROW(o.Check(), InputError);
  o.view_bottom_share = 0.0;
  EXPECT_NO_THROW(o.Check());
}

}  // namespace
}  // namespace stemmap::dense
