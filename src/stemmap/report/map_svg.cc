#include "stemmap/report/map_svg.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"

namespace stemmap::report {

void MapOptions::Check() const {
  if (!(plot_radius_m > 0)) throw InputError("the map's plot radius must be positive");
  if (size_px < 200 || size_px > 4000) throw InputError("the map's size must be 200-4000 px");
  if (!(stem_scale >= 1 && stem_scale <= 20)) {
    throw InputError("the map's stem scale must be in [1, 20]");
  }
}

namespace {

// Screen geometry: plot-frame metres to SVG pixels, turned north up when north is known.
class MapFrame {
 public:
  MapFrame(const MapOptions& o, double extent_m)
      : px_per_m_((o.size_px - 2 * kMarginPx) / (2 * extent_m)), c_(0.5 * o.size_px) {
    // Turning by 90° − (north's azimuth) puts north at the top.
    const double turn = o.north_azimuth_deg ? (90.0 - *o.north_azimuth_deg) * M_PI / 180 : 0.0;
    cos_ = std::cos(turn);
    sin_ = std::sin(turn);
  }
  // SVG's y grows downward; the map's y points up.
  Eigen::Vector2d Px(const Eigen::Vector2d& xy) const {
    const Eigen::Vector2d m(cos_ * xy.x() - sin_ * xy.y(), sin_ * xy.x() + cos_ * xy.y());
    return {c_ + px_per_m_ * m.x(), c_ - px_per_m_ * m.y()};
  }
  // The plot point at `distance_m` and plot azimuth `azimuth_deg`, in pixels.
  Eigen::Vector2d Polar(double distance_m, double azimuth_deg) const {
    const double a = azimuth_deg * M_PI / 180;
    return Px(distance_m * Eigen::Vector2d(std::cos(a), std::sin(a)));
  }
  double px_per_m() const { return px_per_m_; }
  double centre() const { return c_; }
  static constexpr double kMarginPx = 36.0;

 private:
  double px_per_m_, c_, cos_ = 1.0, sin_ = 0.0;
};

// The plot azimuth (of eight) whose ring label at `radius_m` stands farthest from every stem.
double ClearestAzimuth(const std::vector<stems::Stem>& stems, double radius_m) {
  double best_az = 45.0, best_gap = -1.0;
  for (int k = 0; k < 8; ++k) {
    const double az = 22.5 + 45.0 * k;
    const Eigen::Vector2d at =
        radius_m * Eigen::Vector2d(std::cos(az * M_PI / 180), std::sin(az * M_PI / 180));
    double gap = 1e9;
    for (const stems::Stem& s : stems) gap = std::min(gap, (s.centre_xy - at).norm());
    if (gap > best_gap) {
      best_gap = gap;
      best_az = az;
    }
  }
  return best_az;
}

std::string Rings(const MapOptions& o, const MapFrame& f, const std::vector<stems::Stem>& stems,
                  double extent_m) {
  std::string svg;
  for (double r = 2.0; r < extent_m; r += 2.0) {
    const Eigen::Vector2d label = f.Polar(r, ClearestAzimuth(stems, r));
    svg += fmt::format(
        "<circle cx=\"{0:.1f}\" cy=\"{0:.1f}\" r=\"{1:.1f}\" fill=\"none\" stroke=\"#d8d8d0\" "
        "stroke-dasharray=\"3 3\"/>\n<text x=\"{2:.1f}\" y=\"{3:.1f}\" fill=\"#a0a098\" "
        "text-anchor=\"middle\">{4:.0f} m</text>\n",
        f.centre(), r * f.px_per_m(), label.x(), label.y() + 4, r);
  }
  svg += fmt::format(
      "<circle cx=\"{0:.1f}\" cy=\"{0:.1f}\" r=\"{1:.1f}\" fill=\"none\" stroke=\"#5a7d4a\" "
      "stroke-width=\"1.5\"/>\n",
      f.centre(), o.plot_radius_m * f.px_per_m());
  return svg;
}

// The ground no keyframe saw past a stem: an annular sector each.
std::string HiddenSectors(const MapFrame& f, const std::vector<stems::HiddenSector>& hidden) {
  std::string svg;
  for (const stems::HiddenSector& h : hidden) {
    const int steps = std::max(2, static_cast<int>(std::ceil(2 * h.half_width_deg)));
    std::string points;
    for (int i = 0; i <= steps; ++i) {
      const Eigen::Vector2d p =
          f.Polar(h.to_m, h.azimuth_deg - h.half_width_deg + 2 * h.half_width_deg * i / steps);
      points += fmt::format("{:.1f},{:.1f} ", p.x(), p.y());
    }
    for (int i = steps; i >= 0; --i) {
      const Eigen::Vector2d p =
          f.Polar(h.from_m, h.azimuth_deg - h.half_width_deg + 2 * h.half_width_deg * i / steps);
      points += fmt::format("{:.1f},{:.1f} ", p.x(), p.y());
    }
    svg += fmt::format("<polygon points=\"{}\" fill=\"#c9c9c0\" fill-opacity=\"0.6\"/>\n", points);
  }
  return svg;
}

// North up: a north arrow and the compass points; else the plot frame's axes.
std::string Orientation(const MapOptions& o, const MapFrame& f) {
  const double c = f.centre();
  if (!o.north_azimuth_deg) {
    const Eigen::Vector2d x = f.Px({1.5, 0.0}), y = f.Px({0.0, 1.5});
    return fmt::format(
        "<line x1=\"{0:.1f}\" y1=\"{0:.1f}\" x2=\"{1:.1f}\" y2=\"{2:.1f}\" stroke=\"#888\"/>\n"
        "<text x=\"{3:.1f}\" y=\"{4:.1f}\" fill=\"#666\">x (first view)</text>\n"
        "<line x1=\"{0:.1f}\" y1=\"{0:.1f}\" x2=\"{5:.1f}\" y2=\"{6:.1f}\" stroke=\"#888\"/>\n"
        "<text x=\"{7:.1f}\" y=\"{8:.1f}\" fill=\"#666\">y</text>\n",
        c, x.x(), x.y(), x.x() + 3, x.y() + 4, y.x(), y.y(), y.x() + 4, y.y());
  }
  std::string svg;
  const double r_px = o.plot_radius_m * f.px_per_m() + 12;
  for (const auto& [label, dx, dy] :
       {std::tuple{"N", 0.0, -1.0}, {"E", 1.0, 0.0}, {"S", 0.0, 1.0}, {"W", -1.0, 0.0}}) {
    svg += fmt::format(
        "<text x=\"{:.1f}\" y=\"{:.1f}\" text-anchor=\"middle\" font-weight=\"bold\" "
        "fill=\"#555\">{}</text>\n",
        c + dx * r_px, c + dy * r_px + 4, label);
  }
  // The arrow in the top right corner, and the first view as a thin line from the centre.
  const double ax = o.size_px - 24.0;
  const Eigen::Vector2d first = f.Polar(1.5, 0.0);
  svg += fmt::format(
      "<path d=\"M {0:.1f} 14 L {1:.1f} 40 L {0:.1f} 33 L {2:.1f} 40 Z\" fill=\"#333\"/>\n"
      "<text x=\"{0:.1f}\" y=\"54\" text-anchor=\"middle\" font-weight=\"bold\">N</text>\n"
      "<line x1=\"{3:.1f}\" y1=\"{3:.1f}\" x2=\"{4:.1f}\" y2=\"{5:.1f}\" stroke=\"#888\"/>\n"
      "<text x=\"{6:.1f}\" y=\"{7:.1f}\" fill=\"#666\">first view</text>\n",
      ax, ax - 7, ax + 7, c, first.x(), first.y(), first.x() + 3, first.y() + 4);
  return svg;
}

}  // namespace

std::string PlotMapSvg(const MapOptions& o, const std::vector<stems::Stem>& stems,
                       const std::vector<Eigen::Vector2d>& camera_path_xy,
                       const std::vector<stems::HiddenSector>& hidden) {
  o.Check();
  double extent_m = o.plot_radius_m + 1.0;
  for (const stems::Stem& s : stems) extent_m = std::max(extent_m, s.centre_xy.norm() + 0.8);
  const MapFrame f(o, extent_m);
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{0}\" "
      "viewBox=\"0 0 {0} {0}\" font-family=\"sans-serif\" font-size=\"11\">\n"
      "<rect width=\"{0}\" height=\"{0}\" fill=\"#fbfbf7\"/>\n",
      o.size_px);
  svg += HiddenSectors(f, hidden);
  svg += Rings(o, f, stems, extent_m);
  svg += Orientation(o, f);
  if (camera_path_xy.size() > 1) {
    svg += "<polyline fill=\"none\" stroke=\"#3a6ea5\" stroke-width=\"1\" points=\"";
    for (const Eigen::Vector2d& p : camera_path_xy) {
      const Eigen::Vector2d q = f.Px(p);
      svg += fmt::format("{:.1f},{:.1f} ", q.x(), q.y());
    }
    svg += "\"/>\n";
  }
  int id = 0;
  for (const stems::Stem& s : stems) {
    ++id;
    const bool inside = s.centre_xy.norm() <= o.plot_radius_m;
    const char* fill = !inside ? "#b8b8b0" : s.flags.empty() ? "#2f5d2a" : "#e08a1e";
    const double r_px = std::max(2.0, 0.5 * s.dbh_m * o.stem_scale * f.px_per_m());
    const Eigen::Vector2d p = f.Px(s.centre_xy);
    svg += fmt::format(
        "<a href=\"#tree-{}\"><circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" fill=\"{}\">"
        "<title>tree {}: DBH {:.1f} cm{}{}</title></circle>\n<text x=\"{:.1f}\" "
        "y=\"{:.1f}\">{}</text></a>\n",
        id, p.x(), p.y(), r_px, fill, id, 100 * s.dbh_m, s.flags.empty() ? "" : ", ",
        fmt::join(s.flags.Names(), ", "), p.x() + r_px + 1, p.y() - r_px, id);
  }
  // Scale bar and legend along the bottom.
  const double y0 = o.size_px - 14.0;
  svg += fmt::format(
      "<line x1=\"12\" y1=\"{2:.1f}\" x2=\"{1:.1f}\" y2=\"{2:.1f}\" stroke=\"#000\" "
      "stroke-width=\"2\"/>\n<text x=\"12\" y=\"{6:.1f}\">5 m</text>\n"
      "<text x=\"{3:.1f}\" y=\"{0:.1f}\" text-anchor=\"end\" fill=\"#444\">stems at {4:g}x "
      "DBH; orange: flagged; grey: outside {5:g} m; shaded: ground hidden behind stems; blue: "
      "camera path</text>\n",
      y0, 12 + 5 * f.px_per_m(), y0 - 16, o.size_px - 12.0, o.stem_scale, o.plot_radius_m, y0 - 21);
  svg += "</svg>\n";
  return svg;
}

}  // namespace stemmap::report
