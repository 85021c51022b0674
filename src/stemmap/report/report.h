#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/report/map_svg.h"
#include "stemmap/stems/stems.h"

namespace stemmap::report {

struct ReportOptions {
  MapOptions map;
  double breast_height_m = 1.37;
  int thumbnail_height_px = 180;  // shown in the page; a click opens the crop at crop_height_px
  int crop_height_px = 540;
  void Check() const;
};

// What the report shows. The pointers must outlive WriteReport.
struct ReportInput {
  const std::vector<stems::Stem>* stems = nullptr;  // tree_id = index + 1, as trees.csv
  const PinholeCamera* camera = nullptr;            // of `images`
  const std::vector<StampedPose>* keyframes = nullptr;
  // BGR keyframe images, one per keyframe; any other count: no pictures.
  const std::vector<cv::Mat>* images = nullptr;
  std::vector<Eigen::Vector2d> camera_path_xy;
  std::string title;
  std::vector<std::pair<std::string, std::string>> metadata;  // label, value: the run
  std::vector<std::pair<std::string, std::string>> figures;   // label, value: plot figures
  std::vector<stems::DbhClass> stand_table;
  std::vector<stems::HiddenSector> hidden;  // ground no keyframe saw past a stem
};

struct ReportSummary {
  int thumbnails = 0;  // stems shown in a keyframe
};

// Writes OUT/map.svg, OUT/report.html (the plot sheet: the run, the figures, the stand table and
// a diameter histogram, the map, one row per tree, every flag explained, a print stylesheet for
// A4) and, per tree, a crop of the keyframe that sees it best at breast height,
// OUT/report/tree_NNN.jpg, with the fitted stem's silhouette edges and the breast-height line
// drawn on it, labelled with its time in the video, so that a forester can check each DBH against
// the picture. All files are written atomically.
ReportSummary WriteReport(const ReportOptions& options, const ReportInput& input,
                          const std::filesystem::path& out_dir);

// Where the circle (centre, radius, plot frame) at height z shows its two silhouette edges in a
// view: the tangent points seen from the camera centre, projected. Empty when the camera is
// inside the circle or either point lies behind the camera or outside the image.
struct SilhouettePx {
  Eigen::Vector2d left, right;  // image points of the two edges (left: smaller u)
};
std::optional<SilhouettePx> ProjectSilhouette(const PinholeCamera& camera,
                                              const Rigid3d& world_from_cam,
                                              const Eigen::Vector2d& centre_xy, double radius_m,
                                              double z_m);

// The keyframe that shows stem `index` best: both edges in the image, nearest the image centre,
// preferring views where no other listed stem stands in front of it. -1 when none shows it.
int BestView(const PinholeCamera& camera, const std::vector<StampedPose>& keyframes,
             const std::vector<stems::Stem>& stems, size_t index, double breast_height_m);

// The crop around a stem's breast height in one image, scaled to `height_px` rows, with the
// silhouette edges (green ticks) and breast-height line drawn.
cv::Mat StemThumbnail(const cv::Mat& image, const SilhouettePx& edges, int height_px);

}  // namespace stemmap::report
