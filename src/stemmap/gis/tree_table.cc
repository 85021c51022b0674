#include "stemmap/gis/tree_table.h"

#include <fmt/format.h>

#include <cmath>

#include "stemmap/core/io.h"
#include "stemmap/gis/georef.h"

namespace stemmap::gis {

std::vector<TreeRow> TreeRows(const TreeRowOptions& o, const std::vector<stems::Stem>& stems,
                              const Georeference& georef) {
  std::vector<Eigen::Vector2d> xy;
  for (const stems::Stem& s : stems) xy.push_back(s.centre_xy);
  std::vector<MapPoint> map;
  if (georef.HasCentre()) map = georef.ToMap(xy);
  std::vector<Eigen::Vector2d> east_north = xy;
  if (georef.HasBearing()) {
    for (size_t i = 0; i < xy.size(); ++i) {
      east_north[i] =
          EastNorth(*georef.options().first_bearing_deg, georef.options().declination_deg, xy[i]);
    }
  }
  std::vector<TreeRow> rows;
  for (size_t i = 0; i < stems.size(); ++i) {
    const stems::Stem& s = stems[i];
    TreeRow r;
    r.tree_id = static_cast<int>(i) + 1;
    r.xy_m = s.centre_xy;
    r.z_m = s.ground_z_m + o.breast_height_m;
    r.dbh_cm = 100 * s.dbh_m;
    r.dbh_sd_cm = 100 * s.dbh_sd_m;
    r.distance_m = s.centre_xy.norm();
    r.azimuth_deg = std::atan2(s.centre_xy.y(), s.centre_xy.x()) * 180.0 / M_PI;
    if (r.azimuth_deg < 0) r.azimuth_deg += 360.0;
    if (georef.HasBearing()) r.bearing_deg = georef.Bearing(s.centre_xy);
    if (!map.empty()) r.map = map[i];
    r.local_xy_m = east_north[i];
    r.n_views = s.n_views;
    r.confidence = s.confidence;
    r.ground_z_m = s.ground_z_m;
    r.n_points = s.n_points;
    r.arc_deg = s.arc_deg;
    r.occluded = s.flags.Has(stems::StemFlag::kOccluded);
    std::vector<std::string_view> flags = s.flags.Names();
    if (std::abs(r.distance_m - o.plot_radius_m) <= s.dbh_m) flags.push_back("plot_edge");
    r.flags = fmt::format("{}", fmt::join(flags, ";"));
    rows.push_back(std::move(r));
  }
  return rows;
}

namespace {

std::string Optional(const std::optional<double>& v, int digits) {
  return v ? fmt::format("{:.{}f}", *v, digits) : std::string();
}

}  // namespace

void WriteTreesCsv(const std::filesystem::path& path, const std::vector<TreeRow>& rows) {
  std::string s =
      "tree_id,x_m,y_m,z_m,dbh_cm,dbh_sd_cm,distance_m,azimuth_deg,bearing_deg,easting_m,"
      "northing_m,lat,lon,n_views,confidence,flags\n";
  for (const TreeRow& r : rows) {
    const std::optional<MapPoint>& m = r.map;
    s += fmt::format(
        "{},{:.3f},{:.3f},{:.3f},{:.1f},{:.1f},{:.2f},{:.1f},{},{},{},{},{},{},{:.2f},{}\n",
        r.tree_id, r.xy_m.x(), r.xy_m.y(), r.z_m, r.dbh_cm, r.dbh_sd_cm, r.distance_m,
        r.azimuth_deg, Optional(r.bearing_deg, 1),
        Optional(m ? std::optional(m->easting_m) : std::nullopt, 3),
        Optional(m ? std::optional(m->northing_m) : std::nullopt, 3),
        Optional(m ? std::optional(m->lat_deg) : std::nullopt, 8),
        Optional(m ? std::optional(m->lon_deg) : std::nullopt, 8), r.n_views, r.confidence,
        r.flags);
  }
  WriteFileAtomic(path, s);
}

std::string_view TreeTableFileName(TreeTableFormat format) {
  return format == TreeTableFormat::kFortls ? "tree.tls.csv" : "tree_data.csv";
}

namespace {

// An angle in [0, 2π).
double Wrapped(double rad) {
  const double a = std::fmod(rad, 2 * M_PI);
  return a < 0 ? a + 2 * M_PI : a;
}

std::string FortlsTable(const std::vector<TreeRow>& rows, const std::string& plot_id,
                        const std::string& video_name) {
  std::string s =
      "\"id\",\"file\",\"tree\",\"x\",\"y\",\"phi\",\"phi.left\",\"phi.right\",\"h.dist\","
      "\"dbh\",\"h\",\"v\",\"n.pts\",\"n.pts.red\",\"n.pts.est\",\"n.pts.red.est\","
      "\"partial.occlusion\"\n";
  for (const TreeRow& r : rows) {
    const Eigen::Vector2d& p = r.local_xy_m;
    const double phi = Wrapped(std::atan2(p.y(), p.x()));
    // Half the angle the section subtends from the centre; its left edge lies counter-clockwise.
    const double half = std::asin(std::min(1.0, 0.005 * r.dbh_cm / std::max(r.distance_m, 1e-6)));
    s += fmt::format(
        "\"{}\",\"{}\",{},{:.3f},{:.3f},{:.5f},{:.5f},{:.5f},{:.3f},{:.1f},NA,NA,{},{},NA,NA,{}\n",
        plot_id, video_name, r.tree_id, p.x(), p.y(), phi, Wrapped(phi + half), Wrapped(phi - half),
        r.distance_m, r.dbh_cm, r.n_points, r.n_points, r.occluded ? 1 : 0);
  }
  return s;
}

std::string FsctTable(const std::vector<TreeRow>& rows) {
  std::string s =
      "TreeId,x_tree_base,y_tree_base,z_tree_base,DBH,CCI_at_BH,Height,Volume_1,Volume_2,"
      "Crown_mean_x,Crown_mean_y,Crown_top_x,Crown_top_y,Crown_top_z,"
      "mean_understory_height_in_5m_radius\n";
  for (const TreeRow& r : rows) {
    const double x = r.map ? r.map->easting_m : r.xy_m.x();
    const double y = r.map ? r.map->northing_m : r.xy_m.y();
    const double cci = std::min(1.0, (180.0 + r.arc_deg) / 360.0);
    s += fmt::format("{},{:.3f},{:.3f},{:.3f},{:.3f},{:.2f},,,,,,,,,\n", r.tree_id, x, y,
                     r.ground_z_m, r.dbh_cm / 100.0, cci);
  }
  return s;
}

}  // namespace

void WriteTreeTable(TreeTableFormat format, const std::filesystem::path& path,
                    const std::vector<TreeRow>& rows, const std::string& plot_id,
                    const std::string& video_name) {
  WriteFileAtomic(path, format == TreeTableFormat::kFortls ? FortlsTable(rows, plot_id, video_name)
                                                           : FsctTable(rows));
}

}  // namespace stemmap::gis
