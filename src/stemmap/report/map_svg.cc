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

std::string PlotMapSvg(const MapOptions& o, const std::vector<stems::Stem>& stems,
                       const std::vector<Eigen::Vector2d>& camera_path_xy) {
  o.Check();
  double extent_m = o.plot_radius_m + 1.0;
  for (const stems::Stem& s : stems) extent_m = std::max(extent_m, s.centre_xy.norm() + 0.8);
  const double margin_px = 36.0;
  const double px_per_m = (o.size_px - 2 * margin_px) / (2 * extent_m);
  const double c = 0.5 * o.size_px;
  // SVG's y grows downward; the plot's y axis points up on the map.
  auto sx = [&](double x) { return c + px_per_m * x; };
  auto sy = [&](double y) { return c - px_per_m * y; };
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{0}\" "
      "viewBox=\"0 0 {0} {0}\" font-family=\"sans-serif\" font-size=\"11\">\n"
      "<rect width=\"{0}\" height=\"{0}\" fill=\"#fbfbf7\"/>\n",
      o.size_px);
  for (double r = 2.0; r < extent_m; r += 2.0) {
    svg += fmt::format(
        "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" fill=\"none\" stroke=\"#d8d8d0\" "
        "stroke-dasharray=\"3 3\"/>\n<text x=\"{:.1f}\" y=\"{:.1f}\" fill=\"#a0a098\">{:.0f} "
        "m</text>\n",
        c, c, r * px_per_m, sx(r * M_SQRT1_2) + 2, sy(r * M_SQRT1_2) - 2, r);
  }
  svg += fmt::format(
      "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" fill=\"none\" stroke=\"#5a7d4a\" "
      "stroke-width=\"1.5\"/>\n",
      c, c, o.plot_radius_m * px_per_m);
  // Axes through the centre: +x is the first frame's horizontal viewing direction.
  svg += fmt::format(
      "<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\" stroke=\"#888\"/>\n"
      "<text x=\"{3:.1f}\" y=\"{4:.1f}\" fill=\"#666\">x (first view)</text>\n"
      "<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" y2=\"{5:.1f}\" stroke=\"#888\"/>\n"
      "<text x=\"{6:.1f}\" y=\"{7:.1f}\" fill=\"#666\">y</text>\n",
      c, c, sx(1.5), sx(1.6), c + 4, sy(1.5), c + 4, sy(1.5));
  if (camera_path_xy.size() > 1) {
    svg += "<polyline fill=\"none\" stroke=\"#3a6ea5\" stroke-width=\"1\" points=\"";
    for (const Eigen::Vector2d& p : camera_path_xy) {
      svg += fmt::format("{:.1f},{:.1f} ", sx(p.x()), sy(p.y()));
    }
    svg += "\"/>\n";
  }
  int id = 0;
  for (const stems::Stem& s : stems) {
    ++id;
    const bool inside = s.centre_xy.norm() <= o.plot_radius_m;
    const char* fill = !inside ? "#b8b8b0" : s.flags.empty() ? "#2f5d2a" : "#e08a1e";
    const double r_px = std::max(2.0, 0.5 * s.dbh_m * o.stem_scale * px_per_m);
    svg += fmt::format(
        "<a href=\"#tree-{}\"><circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" fill=\"{}\">"
        "<title>tree {}: DBH {:.1f} cm{}{}</title></circle>\n<text x=\"{:.1f}\" "
        "y=\"{:.1f}\">{}</text></a>\n",
        id, sx(s.centre_xy.x()), sy(s.centre_xy.y()), r_px, fill, id, 100 * s.dbh_m,
        s.flags.empty() ? "" : ", ", fmt::join(s.flags.Names(), ", "),
        sx(s.centre_xy.x()) + r_px + 1, sy(s.centre_xy.y()) - r_px, id);
  }
  // Scale bar and legend along the bottom.
  const double y0 = o.size_px - 14.0;
  svg += fmt::format(
      "<line x1=\"12\" y1=\"{0:.1f}\" x2=\"{1:.1f}\" y2=\"{0:.1f}\" stroke=\"#000\" "
      "stroke-width=\"2\"/>\n<text x=\"12\" y=\"{2:.1f}\">5 m</text>\n"
      "<text x=\"{3:.1f}\" y=\"{0:.1f}\" text-anchor=\"end\" fill=\"#444\">stems at {4:g}x "
      "DBH; orange: flagged; grey: outside {5:g} m; blue: camera path</text>\n",
      y0, 12 + 5 * px_per_m, y0 - 5, o.size_px - 12.0, o.stem_scale, o.plot_radius_m);
  svg += "</svg>\n";
  return svg;
}

}  // namespace stemmap::report
