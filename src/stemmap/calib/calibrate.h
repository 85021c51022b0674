#pragma once

#include <filesystem>
#include <string>

#include "stemmap/camera/camera.h"

namespace stemmap::calib {

// `stemmap calibrate`: intrinsics from a video of a printed checkerboard, filmed with the same
// phone and video mode as the plots (the field of view changes between modes).
// How much of the distortion model a lens needs. A main camera keeps a residue that k1 and k2
// describe; k3 would be fitted to noise, since a board held at arm's length rarely reaches the
// image's corners. A wide lens (about 100°) bends most toward them, and needs k3 as well.
enum class LensKind { kMain, kWide };
LensKind ParseLensKind(const std::string& name);  // "main" or "wide"; InputError otherwise
std::string ToString(LensKind lens);

struct CalibrateOptions {
  int inner_cols = 9;  // inner corners along the board's long side
  int inner_rows = 6;  // and along its short side
  double square_m = 0.025;
  int max_views = 40;     // board views used, spread over the video
  int scan_frames = 200;  // frames searched for the board, spread over the video
  LensKind lens = LensKind::kMain;
  void Check() const;
};

struct CalibrateSummary {
  PinholeCamera camera;
  int views = 0;
  double rms_px = 0.0;
  std::string BriefReport() const;
};

// Writes `out_yaml` (OpenCV YAML: image_width, image_height, camera_matrix,
// distortion_coefficients, rms_px) atomically. Throws InputError when the board is found in too
// few frames.
CalibrateSummary RunCalibrate(const CalibrateOptions& options, const std::filesystem::path& video,
                              const std::filesystem::path& out_yaml);

// Reads the camera from an OpenCV YAML file (camera_matrix, distortion_coefficients,
// image_width, image_height) and scales it to `width` x `height` (same aspect ratio required).
PinholeCamera ReadCalibration(const std::filesystem::path& path, int width, int height);

}  // namespace stemmap::calib
