#include "stemmap/report/report.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::report {

namespace {

std::string HtmlEscape(std::string_view s) {
  std::string out;
  for (char ch : s) {
    switch (ch) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += ch;
    }
  }
  return out;
}

double AzimuthDeg(const Eigen::Vector2d& p) {
  const double az = std::atan2(p.y(), p.x()) * 180.0 / M_PI;
  return az < 0 ? az + 360.0 : az;
}

// Whether a nearer listed stem covers part of stem `index` as seen from `eye_xy`.
bool HiddenBehindAnother(const std::vector<stems::Stem>& stems, size_t index,
                         const Eigen::Vector2d& eye_xy) {
  const Eigen::Vector2d to_i = stems[index].centre_xy - eye_xy;
  const double d_i = to_i.norm();
  const double half_i = std::asin(std::min(1.0, 0.5 * stems[index].dbh_m / d_i));
  for (size_t j = 0; j < stems.size(); ++j) {
    if (j == index) continue;
    const Eigen::Vector2d to_j = stems[j].centre_xy - eye_xy;
    const double d_j = to_j.norm();
    if (d_j >= d_i) continue;
    const double half_j = std::asin(std::min(1.0, 0.5 * stems[j].dbh_m / d_j));
    const double apart = std::acos(std::clamp(to_i.dot(to_j) / (d_i * d_j), -1.0, 1.0));
    if (apart < half_i + half_j) return true;
  }
  return false;
}

}  // namespace

void ReportOptions::Check() const {
  map.Check();
  if (!(breast_height_m > 0 && breast_height_m < 5)) {
    throw InputError("breast height must be in (0, 5) m");
  }
  if (thumbnail_height_px < 32 || thumbnail_height_px > 1024) {
    throw InputError("the report's thumbnail height must be 32-1024 px");
  }
}

std::optional<SilhouettePx> ProjectSilhouette(const PinholeCamera& camera,
                                              const Rigid3d& world_from_cam,
                                              const Eigen::Vector2d& centre_xy, double radius_m,
                                              double z_m) {
  const Eigen::Vector2d eye = world_from_cam.translation.head<2>();
  const Eigen::Vector2d v = centre_xy - eye;
  const double d = v.norm();
  if (!(d > radius_m) || radius_m <= 0) return std::nullopt;
  // Tangent points: at angle ±asin(r/d) from the line to the centre, sqrt(d²-r²) from the eye.
  const double a = std::asin(radius_m / d), len = std::sqrt(d * d - radius_m * radius_m);
  const Rigid3d cam_from_world = world_from_cam.Inverse();
  Eigen::Vector2d px[2];
  for (int k = 0; k < 2; ++k) {
    const double s = k == 0 ? a : -a;
    const Eigen::Vector2d dir(std::cos(s) * v.x() - std::sin(s) * v.y(),
                              std::sin(s) * v.x() + std::cos(s) * v.y());
    const Eigen::Vector2d t = eye + len * dir / d;
    const Eigen::Vector3d p_cam = cam_from_world * Eigen::Vector3d(t.x(), t.y(), z_m);
    if (p_cam.z() < 0.1) return std::nullopt;
    px[k] = camera.ImageFromCam(p_cam);
    if (!(px[k].x() >= 0 && px[k].x() < camera.width && px[k].y() >= 0 &&
          px[k].y() < camera.height)) {
      return std::nullopt;
    }
  }
  if (px[0].x() > px[1].x()) std::swap(px[0], px[1]);
  return SilhouettePx{px[0], px[1]};
}

int BestView(const PinholeCamera& camera, const std::vector<StampedPose>& keyframes,
             const std::vector<stems::Stem>& stems, size_t index, double breast_height_m) {
  const stems::Stem& s = stems[index];
  int best = -1;
  double best_score = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const Rigid3d& pose = keyframes[k].world_from_cam;
    const auto edges =
        ProjectSilhouette(camera, pose, s.centre_xy, 0.5 * s.dbh_m, s.ground_z_m + breast_height_m);
    if (!edges) continue;
    // Off-centre distance in image widths; a hidden stem ranks after every clear view.
    double score = std::abs(0.5 * (edges->left.x() + edges->right.x()) - camera.cx) / camera.width;
    if (HiddenBehindAnother(stems, index, pose.translation.head<2>())) score += 10.0;
    if (score < best_score) {
      best_score = score;
      best = static_cast<int>(k);
    }
  }
  return best;
}

cv::Mat StemThumbnail(const cv::Mat& image, const SilhouettePx& edges, int height_px) {
  const double width_px = std::max(1.0, edges.right.x() - edges.left.x());
  const Eigen::Vector2d mid = 0.5 * (edges.left + edges.right);
  const double half_w = std::max(1.6 * width_px, 40.0), half_h = 1.25 * half_w;
  const cv::Rect box(static_cast<int>(std::floor(mid.x() - half_w)),
                     static_cast<int>(std::floor(mid.y() - half_h)),
                     static_cast<int>(std::ceil(2 * half_w)),
                     static_cast<int>(std::ceil(2 * half_h)));
  // Grey where the box leaves the image.
  cv::Mat crop(box.size(), image.type(), cv::Scalar::all(96));
  const cv::Rect inside = box & cv::Rect(0, 0, image.cols, image.rows);
  if (inside.area() > 0) image(inside).copyTo(crop(inside - box.tl()));
  const double scale = static_cast<double>(height_px) / box.height;
  cv::Mat out;
  cv::resize(crop, out, cv::Size(), scale, scale, scale < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
  if (out.channels() == 1) cv::cvtColor(out, out, cv::COLOR_GRAY2BGR);
  // Sub-pixel drawing: cv::line takes coordinates with `shift` fractional bits.
  constexpr int kShift = 4;
  auto at = [&](const Eigen::Vector2d& p) {
    return cv::Point(static_cast<int>(std::lround((p.x() - box.x) * scale * (1 << kShift))),
                     static_cast<int>(std::lround((p.y() - box.y) * scale * (1 << kShift))));
  };
  const Eigen::Vector2d reach(0.7 * width_px, 0.0);
  cv::line(out, at(edges.left - reach), at(edges.right + reach), cv::Scalar(0, 220, 255), 1,
           cv::LINE_AA, kShift);
  const Eigen::Vector2d tick(0.0, std::max(0.6 * width_px, 12.0 / scale));
  for (const Eigen::Vector2d& e : {edges.left, edges.right}) {
    cv::line(out, at(e - tick), at(e + tick), cv::Scalar(40, 230, 40), 1, cv::LINE_AA, kShift);
  }
  return out;
}

ReportSummary WriteReport(const ReportOptions& o, const ReportInput& in,
                          const std::filesystem::path& out_dir) {
  o.Check();
  if (!in.stems || !in.camera || !in.keyframes || !in.images) {
    throw InputError("report: stems, camera, keyframes and images are required");
  }
  // Without the keyframes' images (a track that kept none) the report still lists every tree.
  const bool have_images = in.images->size() == in.keyframes->size();
  if (!have_images) spdlog::warn("report: no keyframe images, so no pictures of the stems");
  const std::vector<stems::Stem>& stems = *in.stems;
  ReportSummary summary;
  // Pictures of an earlier run's trees would outlive their rows.
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(out_dir / "report", ec)) {
    if (e.path().filename().string().starts_with("tree_")) std::filesystem::remove(e.path(), ec);
  }
  const std::string map = PlotMapSvg(o.map, stems, in.camera_path_xy);
  WriteFileAtomic(out_dir / "map.svg", map);

  std::string rows;
  for (size_t i = 0; i < stems.size(); ++i) {
    const stems::Stem& s = stems[i];
    const int id = static_cast<int>(i) + 1;
    std::string picture = have_images ? "<td>not in view</td>" : "<td>no picture kept</td>";
    const int k = BestView(*in.camera, *in.keyframes, stems, i, o.breast_height_m);
    if (have_images && k >= 0 && !(*in.images)[k].empty()) {
      const auto edges =
          ProjectSilhouette(*in.camera, (*in.keyframes)[k].world_from_cam, s.centre_xy,
                            0.5 * s.dbh_m, s.ground_z_m + o.breast_height_m);
      if (!edges) throw ProcessingError("report: the best view lost the stem");  // cannot happen
      std::vector<uchar> jpeg;
      cv::imencode(".jpg", StemThumbnail((*in.images)[k], *edges, o.thumbnail_height_px), jpeg,
                   {cv::IMWRITE_JPEG_QUALITY, 88});
      const std::string name = fmt::format("report/tree_{:03d}.jpg", id);
      WriteFileAtomic(out_dir / name,
                      std::string_view(reinterpret_cast<const char*>(jpeg.data()), jpeg.size()));
      picture =
          fmt::format("<td><img src=\"{}\" alt=\"tree {}\"><br>keyframe {}</td>", name, id, k);
      ++summary.thumbnails;
    }
    const bool inside = s.centre_xy.norm() <= o.map.plot_radius_m;
    rows += fmt::format(
        "<tr "
        "id=\"tree-{}\"{}><td>{}</td><td>{:.2f}</td><td>{:.2f}</td><td>{:.2f}</td><td>{:.1f}</td>"
        "<td><b>{:.1f}</b></td><td>{:.1f}</td><td>{}</td><td>{}</td>{}</tr>\n",
        id, inside ? "" : " class=\"out\"", id, s.centre_xy.x(), s.centre_xy.y(),
        s.centre_xy.norm(), AzimuthDeg(s.centre_xy), 100 * s.dbh_m, 100 * s.dbh_sd_m, s.n_views,
        HtmlEscape(fmt::format("{}", fmt::join(s.flags.Names(), " "))), picture);
  }
  std::string figures;
  for (const auto& [label, value] : in.figures) {
    figures +=
        fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", HtmlEscape(label), HtmlEscape(value));
  }
  const std::string html = fmt::format(
      "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{0}</title>\n<style>\n"
      "body {{ font-family: sans-serif; margin: 1.5em; color: #222; }}\n"
      "table {{ border-collapse: collapse; }} td, th {{ padding: 3px 8px; "
      "border-bottom: 1px solid #ddd; text-align: right; vertical-align: middle; }}\n"
      "tr.out {{ color: #999; }} img {{ display: block; }}\n</style></head><body>\n"
      "<h1>{0}</h1>\n<table>\n{1}</table>\n<h2>Stem map</h2>\n{2}\n<h2>Trees</h2>\n"
      "<p>Each picture is the keyframe that shows the stem best at breast height ({3:g} m above "
      "the ground at the stem): the green ticks are where the reported DBH puts the stem's "
      "edges, the yellow line is breast height. Ticks off the bark edges mean a diameter to "
      "check. Grey rows lie outside the {4:g}-m plot. Flags: <i>occluded</i> a nearer stem hid "
      "part of its edges; <i>one_sided</i> both edges were seen in too few views, the DBH rests "
      "on one side; <i>no_silhouette</i> no edges fitted, the DBH is the point cloud's width; "
      "<i>depth_smeared</i> a far stem placed by its width across the line of sight; "
      "<i>silhouette_only</i> a stem nearer ones hid for most of the turn, found by its edges "
      "alone; "
      "<i>few_views</i> fewer than 4 views measured it. Flagged stems are the ones to look "
      "at first.</p>\n<table>\n<tr><th>tree</th><th>x "
      "m</th><th>y m</th><th>distance m</th><th>azimuth &deg;</th><th>DBH cm</th><th>SD "
      "cm</th><th>views</th><th>flags</th><th>at breast height</th></tr>\n{5}</table>\n"
      "</body></html>\n",
      HtmlEscape(in.title.empty() ? "stemmap plot report" : in.title), figures, map,
      o.breast_height_m, o.map.plot_radius_m, rows);
  WriteFileAtomic(out_dir / "report.html", html);
  spdlog::info("report: {} trees, {} with a picture, map.svg and report.html", stems.size(),
               summary.thumbnails);
  return summary;
}

}  // namespace stemmap::report
