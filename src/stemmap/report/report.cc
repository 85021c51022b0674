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
  if (crop_height_px < thumbnail_height_px || crop_height_px > 2048) {
    throw InputError("the report's crop height must be from the thumbnail height to 2048 px");
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
        ProjectSilhouette(camera, pose, s.centre_xy, 0.5 * s.dbh_m, s.floor_z_m + breast_height_m);
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

namespace {

// Each flag in a forester's words, for the legend and the rows' tooltips.
constexpr std::pair<std::string_view, std::string_view> kFlagMeanings[] = {
    {"occluded", "a nearer stem covered part of this one in some views: check the picture"},
    {"one_sided",
     "both edges were seen together in only a few views: the diameter rests mostly on one edge"},
    {"few_views", "measured in fewer than 4 views"},
    {"no_silhouette",
     "its edges could not be traced in the pictures: the diameter comes from the 3D points and "
     "is less precise"},
    {"depth_smeared", "a far stem: its distance is less certain than its width"},
    {"silhouette_only",
     "hidden behind nearer stems for most of the turn and found from its edges alone: confirm "
     "it on the picture"},
    {"width_from_stand",
     "a nearer stem hid one of its edges wherever it could show: the diameter is the plot's "
     "typical one between the width seen and the widest that stays hidden (see its SD); measure "
     "it by tape"},
    {"plot_edge",
     "a borderline tree: its centre lies within one diameter of the plot edge; it is counted "
     "when the centre is inside"},
};

std::string KeyValueRows(const std::vector<std::pair<std::string, std::string>>& rows) {
  std::string html;
  for (const auto& [label, value] : rows) {
    html += fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", HtmlEscape(label), HtmlEscape(value));
  }
  return html;
}

// The stand table and a histogram of stems/ha by DBH class (inline SVG).
std::string StandTableHtml(const std::vector<stems::DbhClass>& table) {
  if (table.empty()) return "<p>No stem in the plot.</p>\n";
  std::string rows;
  double most = 0.0;
  for (const stems::DbhClass& c : table) {
    rows += fmt::format("<tr><td>{:g}-{:g}</td><td>{}</td><td>{:.0f}</td><td>{:.2f}</td></tr>\n",
                        c.from_cm, c.to_cm, c.stems, c.stems_per_ha, c.basal_area_m2_per_ha);
    most = std::max(most, c.stems_per_ha);
  }
  const int bar_w = 36, h = 150, top = 30, bottom = 20;
  const int w = std::max(240, static_cast<int>(table.size()) * bar_w + 20);
  std::string bars;
  for (size_t i = 0; i < table.size(); ++i) {
    const stems::DbhClass& c = table[i];
    const double bh = most > 0 ? (h - top - bottom) * c.stems_per_ha / most : 0.0;
    const double x = 10 + static_cast<double>(i) * bar_w;
    bars += fmt::format(
        "<rect x=\"{:.0f}\" y=\"{:.1f}\" width=\"{}\" height=\"{:.1f}\" fill=\"#5a7d4a\"/>"
        "<text x=\"{:.0f}\" y=\"{:.1f}\" text-anchor=\"middle\">{:.0f}</text>"
        "<text x=\"{:.0f}\" y=\"{}\" text-anchor=\"middle\">{:g}</text>\n",
        x + 2, h - bottom - bh, bar_w - 4, bh, x + bar_w / 2.0, h - bottom - bh - 3, c.stems_per_ha,
        x + bar_w / 2.0, h - 6, c.from_cm);
  }
  return fmt::format(
      "<div class=\"stand\"><table>\n<tr><th>DBH class cm</th><th>stems</th><th>stems/ha</th>"
      "<th>basal area m²/ha</th></tr>\n{}</table>\n<svg xmlns=\"http://www.w3.org/2000/svg\" "
      "width=\"{}\" height=\"{}\" font-family=\"sans-serif\" font-size=\"10\">\n"
      "<text x=\"10\" y=\"10\">stems/ha by DBH class (from, cm)</text>\n{}</svg></div>\n",
      rows, w, h, bars);
}

// The picture cell of one tree: its crop written to OUT/report/tree_NNN.jpg, shown small and
// opening full size, with its time in the video.
std::string PictureCell(const ReportOptions& o, const ReportInput& in, size_t i,
                        const std::filesystem::path& out_dir, int* written) {
  const bool have_images = in.images->size() == in.keyframes->size();
  if (!have_images) return "<td>no picture kept</td>";
  const std::vector<stems::Stem>& stems = *in.stems;
  const int k = BestView(*in.camera, *in.keyframes, stems, i, o.breast_height_m);
  if (k < 0 || (*in.images)[k].empty()) return "<td>not in view</td>";
  const stems::Stem& s = stems[i];
  const StampedPose& view = (*in.keyframes)[k];
  const auto edges = ProjectSilhouette(*in.camera, view.world_from_cam, s.centre_xy, 0.5 * s.dbh_m,
                                       s.floor_z_m + o.breast_height_m);
  if (!edges) throw ProcessingError("report: the best view lost the stem");  // cannot happen
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", StemThumbnail((*in.images)[k], *edges, o.crop_height_px), jpeg,
               {cv::IMWRITE_JPEG_QUALITY, 88});
  const std::string name = fmt::format("report/tree_{:03d}.jpg", i + 1);
  WriteFileAtomic(out_dir / name,
                  std::string_view(reinterpret_cast<const char*>(jpeg.data()), jpeg.size()));
  ++*written;
  return fmt::format(
      "<td><a href=\"{0}\"><img src=\"{0}\" height=\"{1}\" alt=\"tree {2}\"></a>"
      "<br>video {3:.1f} s</td>",
      name, o.thumbnail_height_px, i + 1, view.t_s);
}

std::string TreeRowsHtml(const ReportOptions& o, const ReportInput& in,
                         const std::filesystem::path& out_dir, int* pictures) {
  std::string rows;
  const std::vector<stems::Stem>& stems = *in.stems;
  for (size_t i = 0; i < stems.size(); ++i) {
    const stems::Stem& s = stems[i];
    const double d = s.centre_xy.norm();
    std::vector<std::string_view> flags = s.flags.Names();
    if (std::abs(d - o.map.plot_radius_m) <= s.dbh_m) flags.push_back("plot_edge");
    std::string flag_cells;
    for (std::string_view f : flags) {
      for (const auto& [name, meaning] : kFlagMeanings) {
        if (name == f) flag_cells += fmt::format("<span title=\"{}\">{}</span> ", meaning, f);
      }
    }
    // Compass bearing from the centre: north's azimuth less the stem's, clockwise.
    const std::optional<double>& north = o.map.north_azimuth_deg;
    const std::string bearing =
        north ? fmt::format(
                    "<td>{:.0f}</td>",
                    std::fmod(std::fmod(*north - AzimuthDeg(s.centre_xy), 360.0) + 360.0, 360.0))
              : "";
    rows += fmt::format(
        "<tr id=\"tree-{}\"{}><td>{}</td><td>{:.2f}</td><td>{:.2f}</td><td>{:.2f}</td>"
        "<td>{:.1f}</td>{}<td><b>{:.1f}</b></td><td>{:.1f}</td><td>{}</td><td>{:.2f}</td>"
        "<td class=\"flags\">{}</td>{}</tr>\n",
        i + 1, d <= o.map.plot_radius_m ? "" : " class=\"out\"", i + 1, s.centre_xy.x(),
        s.centre_xy.y(), d, AzimuthDeg(s.centre_xy), bearing, 100 * s.dbh_m, 100 * s.dbh_sd_m,
        s.n_views, s.confidence, flag_cells, PictureCell(o, in, i, out_dir, pictures));
  }
  return rows;
}

}  // namespace

ReportSummary WriteReport(const ReportOptions& o, const ReportInput& in,
                          const std::filesystem::path& out_dir) {
  o.Check();
  if (!in.stems || !in.camera || !in.keyframes || !in.images) {
    throw InputError("report: stems, camera, keyframes and images are required");
  }
  // Without the keyframes' images (a track that kept none) the report still lists every tree.
  if (in.images->size() != in.keyframes->size()) {
    spdlog::warn("report: no keyframe images, so no pictures of the stems");
  }
  ReportSummary summary;
  // Pictures of an earlier run's trees would outlive their rows.
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(out_dir / "report", ec)) {
    if (e.path().filename().string().starts_with("tree_")) std::filesystem::remove(e.path(), ec);
  }
  const std::string map = PlotMapSvg(o.map, *in.stems, in.camera_path_xy, in.hidden);
  WriteFileAtomic(out_dir / "map.svg", map);
  const std::string rows = TreeRowsHtml(o, in, out_dir, &summary.thumbnails);
  std::string legend;
  for (const auto& [name, meaning] : kFlagMeanings) {
    legend += fmt::format("<dt>{}</dt><dd>{}</dd>\n", name, meaning);
  }
  const std::string html = fmt::format(
      "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{0}</title>\n<style>\n"
      "body {{ font-family: sans-serif; margin: 1.5em; color: #222; }}\n"
      "table {{ border-collapse: collapse; margin-bottom: 1em; }} td, th {{ padding: 3px 8px; "
      "border-bottom: 1px solid #ddd; text-align: right; vertical-align: middle; }}\n"
      "th {{ text-align: left; }} tr.out {{ color: #999; }} img {{ display: block; }}\n"
      ".sheet {{ display: flex; flex-wrap: wrap; gap: 2em; }} .stand {{ display: flex; gap: 1em; "
      "align-items: flex-end; }} svg {{ max-width: 100%; height: auto; }}\n"
      "dt {{ font-style: italic; float: left; clear: left; width: 9em; }} dd {{ margin-left: "
      "10em; }} td.flags span {{ border-bottom: 1px dotted #888; cursor: help; }}\n"
      "@page {{ size: A4; margin: 12mm; }}\n"
      "@media print {{ body {{ margin: 0; font-size: 9pt; }} a {{ color: inherit; "
      "text-decoration: none; }} tr {{ break-inside: avoid; }} h2 {{ break-after: avoid; }} "
      ".map svg {{ width: 150mm; }} img {{ height: 28mm; width: auto; }} .trees {{ "
      "break-before: page; }} }}\n</style></head><body>\n"
      "<h1>{0}</h1>\n<div class=\"sheet\"><div><h2>Run</h2><table>\n{1}</table></div>\n"
      "<div><h2>Plot figures</h2><table>\n{2}</table></div></div>\n"
      "<h2>Stand table</h2>\n{3}<h2>Stem map</h2>\n<div class=\"map\">{4}</div>\n"
      "<div class=\"trees\"><h2>Trees</h2>\n"
      "<p>Each picture is the keyframe that shows the stem best at breast height ({5:g} m above "
      "the ground at the stem), with its time in the video; click it for the full-size crop. The "
      "green ticks are where the reported DBH puts the stem's edges, the yellow line is breast "
      "height: ticks off the bark edges mean a diameter to check. Grey rows lie outside the "
      "{6:g}-m plot. Flagged stems are the ones to look at first:</p>\n<dl>\n{7}</dl>\n"
      "<table>\n<tr><th>tree</th><th>x m</th><th>y m</th><th>distance m</th><th>azimuth "
      "&deg;</th>{8}<th>DBH cm</th><th>SD cm</th><th>views</th><th>confidence</th><th>flags</th>"
      "<th>at breast height</th></tr>\n{9}</table></div>\n</body></html>\n",
      HtmlEscape(in.title.empty() ? "stemmap plot report" : in.title), KeyValueRows(in.metadata),
      KeyValueRows(in.figures), StandTableHtml(in.stand_table), map, o.breast_height_m,
      o.map.plot_radius_m, legend, o.map.north_azimuth_deg ? "<th>bearing &deg;</th>" : "", rows);
  WriteFileAtomic(out_dir / "report.html", html);
  spdlog::info("report: {} trees, {} with a picture, map.svg and report.html", in.stems->size(),
               summary.thumbnails);
  return summary;
}

}  // namespace stemmap::report
