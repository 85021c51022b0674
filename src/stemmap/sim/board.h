#pragma once

// A video of a printed checkerboard held before a simulated phone camera, as a forester records
// it to calibrate the phone once (`stemmap calibrate`): the same lens as the plot videos, the
// board in many poses that together reach the corners of the image, where a wide lens distorts
// most.
#include <filesystem>
#include <opencv2/core.hpp>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/core/rng.h"

namespace stemmap::sim {

struct BoardVideoOptions {
  int inner_cols = 9;  // inner corners along the board's long side (`calibrate --board`)
  int inner_rows = 6;
  double square_m = 0.025;  // `calibrate --square`, in metres
  int views = 48;           // board poses, one frame each
  double fps = 2.0;         // one pose every half second, as a person turns the board
  // The board is held where its diagonal spans this share of the image's width (nearer for a
  // wider lens), its face turned up to max_tilt_deg from the camera: the foreshortening of its
  // corners is what tells the focal length from the distance.
  double min_width_share = 0.35;
  double max_width_share = 0.55;
  double max_tilt_deg = 35.0;
  int supersample = 3;      // samples per pixel along each axis: the squares' edges anti-aliased
  double noise_grey = 2.0;  // sensor noise, SD in grey levels
  void Check() const;
};

// The board's pose in the camera (cam_from_board: the board's first inner corner at its origin,
// its face the plane z = 0) for view `i`: the board's centre is aimed at the points of a grid
// over the image in turn, so that the views together cover the whole field; where the board
// would leave the image, its aim moves toward the image's centre until all of it is in view.
Rigid3d BoardPose(const BoardVideoOptions& o, const PinholeCamera& camera, int i, Rng* rng);

// The grey image (CV_8UC1) of the board at cam_from_board through the camera's lens (its
// distortion included), on a mid-grey background.
cv::Mat RenderBoard(const BoardVideoOptions& o, const PinholeCamera& camera,
                    const Rigid3d& cam_from_board, Rng* rng);

// Writes the board video (H.264, BGR frames of the camera's size) to `video`.
void WriteBoardVideo(const BoardVideoOptions& o, const PinholeCamera& camera, uint64_t seed,
                     double bitrate_mbps, const std::filesystem::path& video);

}  // namespace stemmap::sim
