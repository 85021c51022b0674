#pragma once

#include <opencv2/core.hpp>

#include "stemmap/camera/camera.h"

namespace stemmap::track {

// A picture taken at `focal_scale` times the camera's focal length (a phone's focus breathing),
// redrawn as the camera itself would have taken it: the lens images a ray at
// c + f s D(p), so the pixel q of the redrawn picture is read at c + s (q - c), whatever the
// distortion D. `camera` is the camera at the picture's own size (its principal point c). A
// scale of 1 returns the picture unchanged (no resampling); bilinear otherwise.
cv::Mat UndoFocalScale(const cv::Mat& image, const PinholeCamera& camera, double focal_scale);

}  // namespace stemmap::track
