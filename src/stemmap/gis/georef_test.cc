#include "stemmap/gis/georef.h"

#include <geodesic.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <random>

#include "stemmap/core/error.h"
#include "stemmap/core/units.h"

namespace stemmap::gis {
namespace {

// Random plot points within 15 m of the centre, seeded.
std::vector<Eigen::Vector2d> PlotPoints(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-15.0, 15.0);
  std::vector<Eigen::Vector2d> xy;
  for (int i = 0; i < n; ++i) xy.emplace_back(u(rng), u(rng));
  return xy;
}

// The contract of docs/output-format.md, written out independently of the code.
Eigen::Vector2d ContractEastNorth(double first_bearing_deg, double declination_deg,
                                  const Eigen::Vector2d& xy) {
  const double bearing = first_bearing_deg + declination_deg - std::atan2(xy.y(), xy.x()) / kDeg;
  return xy.norm() * Eigen::Vector2d(std::sin(bearing * kDeg), std::cos(bearing * kDeg));
}

TEST(Bearing, TheFirstViewHasTheFirstBearingAndTheLeftIsAQuarterTurnLess) {
  EXPECT_NEAR(BearingDeg(30.0, 0.0, {5.0, 0.0}), 30.0, 1e-12);
  EXPECT_NEAR(BearingDeg(30.0, 0.0, {0.0, 5.0}), 300.0, 1e-12);
  EXPECT_NEAR(BearingDeg(30.0, 2.5, {0.0, -5.0}), 122.5, 1e-12);
  EXPECT_NEAR(BearingDeg(350.0, 15.0, {1.0, 0.0}), 5.0, 1e-12);
  const Eigen::Vector2d en = EastNorth(90.0, 0.0, {4.0, 0.0});
  EXPECT_NEAR(en.x(), 4.0, 1e-12);
  EXPECT_NEAR(en.y(), 0.0, 1e-12);
}

TEST(Bearing, EastAndNorthFollowTheContractAndKeepTheDistance) {
  for (const double first : {0.0, 47.3, 181.0, 359.9}) {
    for (const double declination : {-12.0, 0.0, 4.4}) {
      for (const Eigen::Vector2d& p : PlotPoints(50, 1)) {
        const double b = BearingDeg(first, declination, p);
        EXPECT_GE(b, 0.0);
        EXPECT_LT(b, 360.0);
        const Eigen::Vector2d en = EastNorth(first, declination, p);
        EXPECT_NEAR((en - ContractEastNorth(first, declination, p)).norm(), 0.0, 1e-9);
        EXPECT_NEAR(en.norm(), p.norm(), 1e-9);
      }
    }
  }
}

TEST(Georeference, AProjectedCentrePlacesTreesByTheContractInTheGivenCrs) {
  GeoreferenceOptions o;
  o.centre_easting_m = 545000.0;
  o.centre_northing_m = 4700000.0;
  o.crs = "EPSG:25830";  // ETRS89 / UTM 30N
  o.first_bearing_deg = 212.0;
  o.declination_deg = 1.5;
  const Georeference g(o);
  const std::vector<Eigen::Vector2d> xy = PlotPoints(40, 2);
  const std::vector<MapPoint> map = g.ToMap(xy);
  ASSERT_EQ(map.size(), xy.size());
  for (size_t i = 0; i < xy.size(); ++i) {
    const Eigen::Vector2d en = ContractEastNorth(212.0, 1.5, xy[i]);
    EXPECT_NEAR(map[i].easting_m, 545000.0 + en.x(), 1e-6);
    EXPECT_NEAR(map[i].northing_m, 4700000.0 + en.y(), 1e-6);
    // Northern Spain, about 3° west.
    EXPECT_NEAR(map[i].lat_deg, 42.45, 0.05);
    EXPECT_NEAR(map[i].lon_deg, -2.45, 0.05);
  }
  EXPECT_EQ(g.GisXy(xy)[3], Eigen::Vector2d(map[3].easting_m, map[3].northing_m));
}

TEST(Georeference, AWgs84CentreKeepsEachTreesGeodesicDistanceAndBearing) {
  geod_geodesic wgs84;
  geod_init(&wgs84, 6378137.0, 1 / 298.257223563);
  for (const auto& [lat, lon] : {std::pair{42.3, -2.5}, {-33.9, 151.2}, {64.1, -21.9}}) {
    GeoreferenceOptions o;
    o.centre_lat_deg = lat;
    o.centre_lon_deg = lon;
    o.first_bearing_deg = 75.0;
    const Georeference g(o);
    const std::vector<Eigen::Vector2d> xy = PlotPoints(30, 3);
    const std::vector<MapPoint> map = g.ToMap(xy);
    for (size_t i = 0; i < xy.size(); ++i) {
      double distance_m = 0, azimuth_deg = 0, back = 0;
      geod_inverse(&wgs84, lat, lon, map[i].lat_deg, map[i].lon_deg, &distance_m, &azimuth_deg,
                   &back);
      const Eigen::Vector2d en = ContractEastNorth(75.0, 0.0, xy[i]);
      const Eigen::Vector2d measured =
          distance_m * Eigen::Vector2d(std::sin(azimuth_deg * kDeg), std::cos(azimuth_deg * kDeg));
      EXPECT_LT((measured - en).norm(), 0.001) << "at " << lat << ", " << lon;
    }
    // The projected columns are the UTM zone's: the trees keep their spacing there too (UTM's
    // scale stays within 0.1 % of 1 across a zone).
    const Eigen::Vector2d a(map[0].easting_m, map[0].northing_m);
    const Eigen::Vector2d b(map[1].easting_m, map[1].northing_m);
    EXPECT_NEAR((a - b).norm(), (xy[0] - xy[1]).norm(), 0.001 * (xy[0] - xy[1]).norm() + 1e-3);
  }
}

TEST(Georeference, WithoutACentreTheGisFrameIsLocal) {
  GeoreferenceOptions o;
  const Georeference plain(o);
  EXPECT_TRUE(plain.GisCrs().IsLocal());
  const std::vector<Eigen::Vector2d> xy = PlotPoints(5, 4);
  EXPECT_EQ(plain.GisXy(xy), xy);
  EXPECT_THROW(plain.ToMap(xy), ProcessingError);
  o.first_bearing_deg = 10.0;
  const Georeference turned(o);
  EXPECT_TRUE(turned.GisCrs().IsLocal());
  EXPECT_LT((turned.GisXy(xy)[2] - ContractEastNorth(10.0, 0.0, xy[2])).norm(), 1e-9);
}

TEST(Georeference, UnusableOptionsAreRefusedWithTheirFlags) {
  auto refused = [](GeoreferenceOptions o, const char* expected) {
    try {
      const Georeference g(o);
      ADD_FAILURE() << "accepted; expected: " << expected;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  GeoreferenceOptions centre;
  centre.centre_lat_deg = 42.0;
  centre.centre_lon_deg = -2.0;
  refused(centre, "--first-bearing");
  GeoreferenceOptions xy;
  xy.centre_easting_m = 500000.0;
  xy.centre_northing_m = 4000000.0;
  xy.first_bearing_deg = 0.0;
  refused(xy, "--crs");
  xy.crs = "EPSG:4326";
  refused(xy, "projected CRS in metres");
  xy.crs = "EPSG:2249";  // Massachusetts, US survey feet
  refused(xy, "projected CRS in metres");
  xy.crs = "not a crs";
  refused(xy, "not a coordinate reference system");
  GeoreferenceOptions both = centre;
  both.first_bearing_deg = 0.0;
  both.centre_easting_m = 1.0;
  both.centre_northing_m = 1.0;
  refused(both, "once");
  GeoreferenceOptions polar = centre;
  polar.first_bearing_deg = 0.0;
  polar.centre_lat_deg = 88.0;
  refused(polar, "±84°");
  GeoreferenceOptions declination;
  declination.declination_deg = 400.0;
  refused(declination, "--declination");
}

}  // namespace
}  // namespace stemmap::gis
