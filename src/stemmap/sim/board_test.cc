#include "stemmap/sim/board.h"

#include <gtest/gtest.h>

#include "stemmap/core/error.h"

namespace stemmap::sim {
namespace {

// The `wide` preset's lens (100°, strong barrel) at a small size.
PinholeCamera WideCamera() {
  return PinholeCamera::FromLensHfov(320, 180, 100.0, -0.25, 0.07, -0.008);
}

// Mean grey of a square of pixels around (x, y).
double MeanAround(const cv::Mat& img, double x, double y) {
  const int half = 1;
  double sum = 0;
  int n = 0;
  for (int v = static_cast<int>(y) - half; v <= static_cast<int>(y) + half; ++v) {
    for (int u = static_cast<int>(x) - half; u <= static_cast<int>(x) + half; ++u) {
      sum += img.at<uchar>(v, u);
      ++n;
    }
  }
  return sum / n;
}

TEST(BoardVideo, EveryViewShowsTheWholeBoardAndTheViewsReachTheCorners) {
  const BoardVideoOptions o;
  for (const PinholeCamera& cam :
       {WideCamera(), PinholeCamera::FromLensHfov(320, 180, 70.0, 0.02, -0.01, 0.0)}) {
    Rng rng(5);
    double farthest = 0.0;  // of a board corner from the image's centre, as a share of the half
                            // diagonal
    for (int i = 0; i < o.views; ++i) {
      const Rigid3d cam_from_board = BoardPose(o, cam, i, &rng);
      for (double x : {-2 * o.square_m, (o.inner_cols + 1) * o.square_m}) {
        for (double y : {-2 * o.square_m, (o.inner_rows + 1) * o.square_m}) {
          const Eigen::Vector3d p = cam_from_board * Eigen::Vector3d(x, y, 0.0);
          ASSERT_GT(p.z(), 0.0) << i;
          const Eigen::Vector2d px = cam.ImageFromCam(p);
          EXPECT_GE(px.x(), 0.0) << i;
          EXPECT_GE(px.y(), 0.0) << i;
          EXPECT_LE(px.x(), cam.width - 1.0) << i;
          EXPECT_LE(px.y(), cam.height - 1.0) << i;
          farthest = std::max(farthest, (px - Eigen::Vector2d(cam.cx, cam.cy)).norm() /
                                            (0.5 * std::hypot(cam.width, cam.height)));
        }
      }
    }
    // Calibration needs the board near the corners, where the distortion is largest.
    EXPECT_GT(farthest, 0.8);
  }
}

TEST(BoardVideo, TheSquaresLieWhereTheLensPutsThem) {
  BoardVideoOptions o;
  o.noise_grey = 0.0;
  const PinholeCamera cam = WideCamera();
  Rng pose_rng(2);
  for (int i = 0; i < 12; ++i) {
    const Rigid3d cam_from_board = BoardPose(o, cam, i, &pose_rng);
    Rng rng(1);
    const cv::Mat img = RenderBoard(o, cam, cam_from_board, &rng);
    // The centres of the squares either side of an inner corner: black where the square's
    // column and row add up to an even number, as the first square beside the first corner.
    for (int c = 0; c < o.inner_cols; c += 4) {
      for (int r = 0; r < o.inner_rows; r += 5) {
        for (int dc : {0, 1}) {
          for (int dr : {0, 1}) {
            const Eigen::Vector3d centre((c - 0.5 + dc) * o.square_m, (r - 0.5 + dr) * o.square_m,
                                         0.0);
            const Eigen::Vector2d px = cam.ImageFromCam(cam_from_board * centre);
            const bool black = (c + dc + r + dr) % 2 == 0;
            const double grey = MeanAround(img, px.x(), px.y());
            if (black) {
              EXPECT_LT(grey, 60.0) << i << " " << c << " " << r;
            } else {
              EXPECT_GT(grey, 195.0) << i << " " << c << " " << r;
            }
          }
        }
      }
    }
  }
}

TEST(BoardVideo, SameSeedSameImageAndBadOptionsAreRefused) {
  const BoardVideoOptions o;
  const PinholeCamera cam = WideCamera();
  Rng a(7), b(7);
  const cv::Mat first = RenderBoard(o, cam, BoardPose(o, cam, 3, &a), &a);
  const cv::Mat second = RenderBoard(o, cam, BoardPose(o, cam, 3, &b), &b);
  EXPECT_EQ(cv::norm(first, second, cv::NORM_INF), 0.0);
  BoardVideoOptions bad;
  bad.views = 2;
  EXPECT_THROW(bad.Check(), InputError);
  bad = BoardVideoOptions();
  bad.max_width_share = 0.2;
  EXPECT_THROW(bad.Check(), InputError);
  bad = BoardVideoOptions();
  bad.supersample = 0;
  EXPECT_THROW(bad.Check(), InputError);
}

}  // namespace
}  // namespace stemmap::sim
