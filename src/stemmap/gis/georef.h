#pragma once

// Where the plot lies on the Earth: the plot frame tied to a compass bearing and a map.
//
// Contract (docs/output-format.md): the plot frame's x is the first view, y is to its left, so a
// point at plot (x, y) has the compass bearing
//   bearing_deg = (first_bearing_deg + declination_deg - atan2(y, x)·180/π) mod 360
// from the centre and lies distance·sin(bearing) east and distance·cos(bearing) north of it. With
// a projected centre (`--plot-centre-xy E,N --crs EPSG:CODE`) east and north are the CRS's own
// axes; with a WGS 84 centre (`--plot-centre LAT,LON`) they are true east and north, and the point
// is placed by the azimuthal equidistant projection at the centre (distance and bearing from the
// centre kept exactly).
#include <Eigen/Core>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "stemmap/core/json_optional.h"

class OGRSpatialReference;
class OGRCoordinateTransformation;

namespace stemmap::gis {

struct GeoreferenceOptions {
  // Plot centre in WGS 84 (degrees; `--plot-centre LAT,LON`).
  std::optional<double> centre_lat_deg, centre_lon_deg;
  // Plot centre in a projected CRS (metres; `--plot-centre-xy E,N`), with that CRS (`--crs`,
  // "EPSG:CODE" or anything GDAL's SetFromUserInput takes; its unit must be the metre).
  std::optional<double> centre_easting_m, centre_northing_m;
  std::string crs;
  // Compass bearing of the first frame's view, clockwise from north (degrees; `--first-bearing`).
  std::optional<double> first_bearing_deg;
  // Magnetic declination, east positive (degrees; `--declination`): added to first_bearing_deg
  // when that was read off a magnetic compass; 0 when it is already a true (or grid) bearing.
  double declination_deg = 0.0;
  bool HasLatLonCentre() const { return centre_lat_deg.has_value(); }
  bool HasProjectedCentre() const { return centre_easting_m.has_value(); }
  bool HasCentre() const { return HasLatLonCentre() || HasProjectedCentre(); }
  void Check() const;
};
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(GeoreferenceOptions, centre_lat_deg, centre_lon_deg,
                                                centre_easting_m, centre_northing_m, crs,
                                                first_bearing_deg, declination_deg)

// Compass bearing (degrees clockwise from north, [0, 360)) of plot point `xy` seen from the
// centre, by the contract above.
double BearingDeg(double first_bearing_deg, double declination_deg, const Eigen::Vector2d& xy);

// Metres east and north of the centre of plot point `xy`.
Eigen::Vector2d EastNorth(double first_bearing_deg, double declination_deg,
                          const Eigen::Vector2d& xy);

// A point on the map: in the projected CRS (`Georeference::ProjectedCrs`) and in WGS 84.
struct MapPoint {
  double easting_m = 0.0, northing_m = 0.0;
  double lat_deg = 0.0, lon_deg = 0.0;
};

// The plot frame on the map. Built once per run (it sets up PROJ transforms).
class Georeference {
 public:
  // Throws InputError for an unknown or non-metric CRS, or a centre without a first bearing.
  explicit Georeference(const GeoreferenceOptions& options);
  ~Georeference();
  Georeference(const Georeference&) = delete;
  Georeference& operator=(const Georeference&) = delete;

  const GeoreferenceOptions& options() const { return options_; }
  bool HasBearing() const { return options_.first_bearing_deg.has_value(); }
  bool HasCentre() const { return options_.HasCentre(); }

  double Bearing(const Eigen::Vector2d& xy) const;  // needs HasBearing()
  // Map positions of plot points (needs HasCentre()).
  std::vector<MapPoint> ToMap(const std::vector<Eigen::Vector2d>& xy) const;
  // Easting and northing alone in ProjectedCrs() (needs HasCentre()): the cloud's millions of
  // points need no latitude and longitude.
  std::vector<Eigen::Vector2d> ProjectedXy(const std::vector<Eigen::Vector2d>& xy) const;

  // The CRS of `MapPoint::easting_m/northing_m` and of cloud.las: the given CRS, or the UTM zone
  // of a WGS 84 centre; null without a centre.
  const OGRSpatialReference* ProjectedCrs() const { return projected_.get(); }
  // The CRS of the GIS layers and their coordinates (`GisXy`): the given projected CRS, WGS 84
  // (longitude, latitude) for a WGS 84 centre, and without a centre a local engineering CRS in
  // metres (east, north of the centre when the first bearing is known, else the plot frame's x, y).
  const OGRSpatialReference& GisCrs() const { return *gis_crs_; }
  std::vector<Eigen::Vector2d> GisXy(const std::vector<Eigen::Vector2d>& xy) const;
  // One line for a person: which CRS and frame the GIS files are in.
  std::string Describe() const;

 private:
  GeoreferenceOptions options_;
  std::unique_ptr<OGRSpatialReference> projected_, gis_crs_, wgs84_, local_;
  // local_: true east and north metres at a WGS 84 centre (azimuthal equidistant).
  std::unique_ptr<OGRCoordinateTransformation> projected_to_wgs84_, local_to_projected_;
};

}  // namespace stemmap::gis
