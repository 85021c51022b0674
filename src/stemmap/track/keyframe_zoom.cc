#include "stemmap/track/keyframe_zoom.h"

#include <opencv2/imgproc.hpp>

namespace stemmap::track {

cv::Mat UndoFocalScale(const cv::Mat& image, const PinholeCamera& camera, double focal_scale) {
  if (focal_scale == 1.0 || image.empty()) return image;
  // Destination pixel q reads the source at s q + (1 - s) c.
  const cv::Matx23d dst_to_src(focal_scale, 0.0, (1.0 - focal_scale) * camera.cx,  //
                               0.0, focal_scale, (1.0 - focal_scale) * camera.cy);
  cv::Mat out;
  cv::warpAffine(image, out, dst_to_src, image.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                 cv::BORDER_REPLICATE);
  return out;
}

}  // namespace stemmap::track
