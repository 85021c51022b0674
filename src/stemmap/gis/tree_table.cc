#include "stemmap/gis/tree_table.h"

#include <fmt/format.h>

#include <cmath>

#include "stemmap/core/io.h"

namespace stemmap::gis {

std::vector<TreeRow> TreeRows(const TreeRowOptions& o, const std::vector<stems::Stem>& stems,
                              const Georeference& georef) {
  std::vector<Eigen::Vector2d> xy;
  for (const stems::Stem& s : stems) xy.push_back(s.centre_xy);
  std::vector<MapPoint> map;
  if (georef.HasCentre()) map = georef.ToMap(xy);
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
    r.n_views = s.n_views;
    r.confidence = s.confidence;
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

}  // namespace stemmap::gis
