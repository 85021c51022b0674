#pragma once

// Silhouette edges of a stem in one keyframe, for the tangent-ray fit (tangent.cc): where the
// stem's predicted outline lies in the image, where nearer stems leave it free, and the edges
// themselves.
#include <Eigen/Core>
#include <array>
#include <optional>
#include <utility>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/stems/tangent.h"

namespace stemmap::stems {

// Bilinear sample of an 8-bit image; -1 outside it (or at NaN). Inline: the silhouette search
// samples every pixel of its windows in two neighbours.
inline float BilinearGray(const cv::Mat& img, double x, double y) {
  if (!(x >= 0 && y >= 0 && x <= img.cols - 2 && y <= img.rows - 2)) return -1.f;
  const int xi = static_cast<int>(x), yi = static_cast<int>(y);
  const double fx = x - xi, fy = y - yi;
  const uchar* r0 = img.ptr<uchar>(yi);
  const uchar* r1 = img.ptr<uchar>(yi + 1);
  return static_cast<float>((1 - fy) * ((1 - fx) * r0[xi] + fx * r0[xi + 1]) +
                            fy * ((1 - fx) * r1[xi] + fx * r1[xi + 1]));
}

struct Edges {
  bool left = false, right = false;
  double x_left = 0, x_right = 0, y = 0;
};

// Where nearer stems leave a view's edge search free, in image columns (side 0: the stem's image
// left, 1: its right). The stem shows from its side's predicted edge inward to inner_end (a
// nearer stem covers the rest), and what lies beyond the edge is seen out to outer_end.
struct EdgeWindow {
  std::array<double, 2> inner_end = {1e9, -1e9};
  std::array<double, 2> outer_end = {-1e9, 1e9};
  std::array<bool, 2> hidden = {false, false};
};

// The depth steps each side of the stem's surface that a view compares a neighbour through
// (TangentOptions::near_depth_steps), and each step's length along the ray (m), for a neighbour
// baseline_px = baseline (m) times the focal length (px) away and the stem's face dist_m out.
std::pair<int, double> NearDepthSteps(const TangentOptions& o, double baseline_px, double dist_m);

// Silhouette columns of the stem (c0, r0) in keyframe k at image row y0, from the disagreement
// between k and its neighbours warped through the stem's surface.
Edges FindEdges(const TangentOptions& o, const TangentViews& v, int k, const Eigen::Vector2d& c0,
                double r0, double breast_z, double x_pred_left, double x_pred_right, double y0,
                const EdgeWindow& window);

// The nearer stems (x, y, radius) in front of a stem at distance d along u from the camera centre
// cc.
std::vector<Eigen::Vector3d> FrontOccluders(const TangentOptions& o, const TangentViews& v,
                                            const Eigen::Vector2d& cc, const Eigen::Vector2d& u,
                                            double d, double r);

// Whether a nearer stem (x, y, radius), seen from the plot centre, shows within the stem (c, r)'s
// own angular width of it (gap or overlap); stems within min_gap_m of its distance do not count.
bool BesideNearerStem(const std::vector<Eigen::Vector3d>& stems, const Eigen::Vector2d& c, double r,
                      double min_gap_m);

// Whether a keyframe (camera centre cc) tries the stem (c, r): its centre at breast_z 0.3 m
// beyond its bark and 0.5 m in front of the camera, within the middle 84 % of the picture's
// width (nearer the border the window around it leaves the picture). Returns that centre in the
// camera frame, or nothing.
std::optional<Eigen::Vector3d> StemInView(const PinholeCamera& cam, const Rigid3d& cam_from_world,
                                          const Eigen::Vector2d& cc, const Eigen::Vector2d& c,
                                          double r, double breast_z);

// Image columns (ascending) of the silhouettes of the vertical circle (centre, r) at height z
// seen from a camera at cc; false when a silhouette lies behind the camera.
bool SilhouetteColumns(const PinholeCamera& cam, const Rigid3d& cam_from_world,
                       const Eigen::Vector2d& cc, const Eigen::Vector2d& centre, double r, double z,
                       std::array<double, 2>* xs);

// The edge search a stem predicted at columns [xl, xr] has beside nearer stems at the given
// columns.
EdgeWindow WindowBesideOccluders(const std::vector<std::array<double, 2>>& occluder_cols, double xl,
                                 double xr, double guard);

}  // namespace stemmap::stems
