#include "stemmap/gis/georef.h"

#include <cpl_error.h>
#include <fmt/format.h>
#include <ogr_spatialref.h>

#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"

namespace stemmap::gis {

namespace {

// GDAL reports through CPLError to stderr; our errors say it in one line instead.
class QuietGdal {
 public:
  QuietGdal() { CPLPushErrorHandler(CPLQuietErrorHandler); }
  ~QuietGdal() { CPLPopErrorHandler(); }
  QuietGdal(const QuietGdal&) = delete;
  QuietGdal& operator=(const QuietGdal&) = delete;
};

std::unique_ptr<OGRSpatialReference> NewSrs() {
  auto srs = std::make_unique<OGRSpatialReference>();
  // x is easting or longitude whatever the CRS's own axis order.
  srs->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return srs;
}

std::unique_ptr<OGRSpatialReference> ParseProjectedCrs(const std::string& text) {
  QuietGdal quiet;
  auto srs = NewSrs();
  if (srs->SetFromUserInput(text.c_str()) != OGRERR_NONE) {
    throw InputError(fmt::format("--crs {}: not a coordinate reference system GDAL knows", text));
  }
  if (!srs->IsProjected() || std::abs(srs->GetLinearUnits() - 1.0) > 1e-9) {
    throw InputError(fmt::format(
        "--crs {}: --plot-centre-xy needs a projected CRS in metres (a UTM zone or a national "
        "grid); for latitude and longitude give --plot-centre LAT,LON",
        text));
  }
  return srs;
}

std::unique_ptr<OGRCoordinateTransformation> NewTransform(const OGRSpatialReference& from,
                                                          const OGRSpatialReference& to) {
  QuietGdal quiet;
  std::unique_ptr<OGRCoordinateTransformation> t(OGRCreateCoordinateTransformation(&from, &to));
  if (!t) throw InputError("no coordinate transformation between the plot's CRS and WGS 84");
  return t;
}

// The UTM zone of a WGS 84 point (the Norway and Svalbard exceptions are not made: a plot's
// coordinates are valid in the regular zone too).
int UtmEpsg(double lat_deg, double lon_deg) {
  const int zone = std::clamp(static_cast<int>(std::floor((lon_deg + 180.0) / 6.0)) + 1, 1, 60);
  return (lat_deg >= 0 ? 32600 : 32700) + zone;
}

void Transform(const OGRCoordinateTransformation& t, std::vector<double>* x,
               std::vector<double>* y) {
  if (x->empty()) return;
  // Transform is not const in GDAL's API, though it keeps no state between calls we rely on.
  auto& ct = const_cast<OGRCoordinateTransformation&>(t);
  if (!ct.Transform(x->size(), x->data(), y->data())) {
    throw ProcessingError("a point of the plot could not be transformed to WGS 84");
  }
}

}  // namespace

void GeoreferenceOptions::Check() const {
  if (centre_lat_deg.has_value() != centre_lon_deg.has_value() ||
      centre_easting_m.has_value() != centre_northing_m.has_value()) {
    throw InputError("a plot centre needs both of its coordinates");
  }
  if (HasLatLonCentre() && HasProjectedCentre()) {
    throw InputError("give the plot centre once: --plot-centre LAT,LON or --plot-centre-xy E,N");
  }
  if (HasLatLonCentre()) {
    if (!(std::abs(*centre_lat_deg) <= 84.0) || !(std::abs(*centre_lon_deg) <= 180.0)) {
      throw InputError(fmt::format(
          "--plot-centre {},{}: latitude must lie within ±84° (the UTM zones; nearer the poles "
          "give --plot-centre-xy in a polar CRS) and longitude within ±180°",
          *centre_lat_deg, *centre_lon_deg));
    }
  }
  if (HasProjectedCentre()) {
    if (!std::isfinite(*centre_easting_m) || !std::isfinite(*centre_northing_m)) {
      throw InputError("--plot-centre-xy must be two finite numbers");
    }
    if (crs.empty()) throw InputError("--plot-centre-xy needs --crs EPSG:CODE");
  } else if (!crs.empty()) {
    throw InputError("--crs is the CRS of --plot-centre-xy, which is not given");
  }
  if (HasCentre() && !first_bearing_deg) {
    throw InputError(
        "a plot centre needs --first-bearing DEG (the compass bearing of the first frame's "
        "view): without it the tree map cannot be turned onto the ground");
  }
  if (first_bearing_deg && !std::isfinite(*first_bearing_deg)) {
    throw InputError("--first-bearing must be a number of degrees");
  }
  if (!(std::abs(declination_deg) <= 180.0)) {
    throw InputError("--declination must lie within ±180°");
  }
}

double BearingDeg(double first_bearing_deg, double declination_deg, const Eigen::Vector2d& xy) {
  const double azimuth_deg = std::atan2(xy.y(), xy.x()) * 180.0 / M_PI;
  const double b = std::fmod(first_bearing_deg + declination_deg - azimuth_deg, 360.0);
  return b < 0 ? b + 360.0 : b;
}

Eigen::Vector2d EastNorth(double first_bearing_deg, double declination_deg,
                          const Eigen::Vector2d& xy) {
  const double b = BearingDeg(first_bearing_deg, declination_deg, xy) * M_PI / 180.0;
  const double d = xy.norm();
  return {d * std::sin(b), d * std::cos(b)};
}

Georeference::Georeference(const GeoreferenceOptions& options) : options_(options) {
  options_.Check();
  QuietGdal quiet;
  wgs84_ = NewSrs();
  wgs84_->SetWellKnownGeogCS("WGS84");
  if (options_.HasProjectedCentre()) {
    projected_ = ParseProjectedCrs(options_.crs);
    gis_crs_ = std::make_unique<OGRSpatialReference>(*projected_);
  } else if (options_.HasLatLonCentre()) {
    projected_ = NewSrs();
    projected_->importFromEPSG(UtmEpsg(*options_.centre_lat_deg, *options_.centre_lon_deg));
    gis_crs_ = std::make_unique<OGRSpatialReference>(*wgs84_);
    local_ = NewSrs();
    local_->SetWellKnownGeogCS("WGS84");
    local_->SetAE(*options_.centre_lat_deg, *options_.centre_lon_deg, 0.0, 0.0);
    local_to_projected_ = NewTransform(*local_, *projected_);
  } else {
    gis_crs_ = NewSrs();
    gis_crs_->SetLocalCS(HasBearing() ? "stemmap plot: metres east and north of the centre"
                                      : "stemmap plot frame: x along the first view, y left, m");
    gis_crs_->SetLinearUnits(SRS_UL_METER, 1.0);
  }
  if (projected_) projected_to_wgs84_ = NewTransform(*projected_, *wgs84_);
}

Georeference::~Georeference() = default;

double Georeference::Bearing(const Eigen::Vector2d& xy) const {
  return BearingDeg(*options_.first_bearing_deg, options_.declination_deg, xy);
}

std::vector<MapPoint> Georeference::ToMap(const std::vector<Eigen::Vector2d>& xy) const {
  const std::vector<Eigen::Vector2d> projected = ProjectedXy(xy);
  std::vector<double> lon(xy.size()), lat(xy.size());
  for (size_t i = 0; i < xy.size(); ++i) {
    lon[i] = projected[i].x();
    lat[i] = projected[i].y();
  }
  Transform(*projected_to_wgs84_, &lon, &lat);
  std::vector<MapPoint> out(xy.size());
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = {projected[i].x(), projected[i].y(), lat[i], lon[i]};
  }
  return out;
}

std::vector<Eigen::Vector2d> Georeference::ProjectedXy(
    const std::vector<Eigen::Vector2d>& xy) const {
  if (!HasCentre()) throw ProcessingError("map positions need a plot centre");
  std::vector<double> e, n;
  e.reserve(xy.size());
  n.reserve(xy.size());
  for (const Eigen::Vector2d& p : xy) {
    const Eigen::Vector2d en = EastNorth(*options_.first_bearing_deg, options_.declination_deg, p);
    e.push_back(en.x() + options_.centre_easting_m.value_or(0.0));
    n.push_back(en.y() + options_.centre_northing_m.value_or(0.0));
  }
  if (options_.HasLatLonCentre()) Transform(*local_to_projected_, &e, &n);
  std::vector<Eigen::Vector2d> out(xy.size());
  for (size_t i = 0; i < out.size(); ++i) out[i] = {e[i], n[i]};
  return out;
}

std::vector<Eigen::Vector2d> Georeference::GisXy(const std::vector<Eigen::Vector2d>& xy) const {
  std::vector<Eigen::Vector2d> out;
  out.reserve(xy.size());
  if (HasCentre()) {
    for (const MapPoint& m : ToMap(xy)) {
      out.emplace_back(options_.HasLatLonCentre() ? Eigen::Vector2d(m.lon_deg, m.lat_deg)
                                                  : Eigen::Vector2d(m.easting_m, m.northing_m));
    }
  } else if (HasBearing()) {
    for (const Eigen::Vector2d& p : xy) {
      out.push_back(EastNorth(*options_.first_bearing_deg, options_.declination_deg, p));
    }
  } else {
    out = xy;
  }
  return out;
}

std::string Georeference::Describe() const {
  if (options_.HasProjectedCentre())
    return fmt::format("{} (plot centre given there)", options_.crs);
  if (options_.HasLatLonCentre()) {
    return fmt::format("WGS 84 (EPSG:4326); projected columns and cloud.las in UTM, EPSG:{}",
                       projected_->GetAuthorityCode(nullptr));
  }
  return HasBearing() ? "local: metres east and north of the plot centre (no centre given)"
                      : "local: the plot frame in metres (no centre or first bearing given)";
}

}  // namespace stemmap::gis
