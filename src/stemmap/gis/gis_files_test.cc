#include "stemmap/gis/gis_files.h"

#include <gdal_priv.h>
#include <geodesic.h>
#include <gtest/gtest.h>
#include <ogrsf_frmts.h>

#include <cmath>

#include "stemmap/core/io.h"
#include "stemmap/core/units.h"

namespace stemmap::gis {
namespace {

namespace fs = std::filesystem;

fs::path GisDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("stemmap_gis_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::vector<stems::Stem> SomeStems() {
  std::vector<stems::Stem> out;
  for (const auto& [x, y, dbh] :
       {std::tuple{3.0, 1.0, 0.31}, {-2.0, 6.5, 0.12}, {0.5, -9.8, 0.45}}) {
    stems::Stem s;
    s.centre_xy = {x, y};
    s.dbh_m = dbh;
    s.dbh_sd_m = 0.01;
    s.n_views = 12;
    s.confidence = 0.99;
    out.push_back(s);
  }
  out[1].flags.Set(stems::StemFlag::kOneSided);
  return out;
}

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};
std::unique_ptr<GDALDataset, DatasetCloser> Open(const fs::path& path) {
  GDALAllRegister();
  return std::unique_ptr<GDALDataset, DatasetCloser>(
      GDALDataset::Open(path.c_str(), GDAL_OF_VECTOR | GDAL_OF_READONLY));
}

// The contract's east and north offsets of plot point `xy`.
Eigen::Vector2d EastNorthByContract(double first_bearing_deg, const Eigen::Vector2d& xy) {
  const double b = (first_bearing_deg - std::atan2(xy.y(), xy.x()) / kDeg) * kDeg;
  return xy.norm() * Eigen::Vector2d(std::sin(b), std::cos(b));
}

TEST(GisFiles, AProjectedCentreGivesLayersWhereTheContractPutsEachTree) {
  const fs::path dir = GisDir("projected");
  GeoreferenceOptions o;
  o.centre_easting_m = 545000.0;
  o.centre_northing_m = 4700000.0;
  o.crs = "EPSG:25830";
  o.first_bearing_deg = 33.0;
  const Georeference georef(o);
  const std::vector<stems::Stem> stems = SomeStems();
  const std::vector<TreeRow> rows = TreeRows({}, stems, georef);
  GisInput in{&rows, {{1.0, 0.0}, {0.0, 1.0}, {-1.0, 0.0}}, 10.0};
  const GisSummary summary = WriteGisFiles(georef, in, dir);
  ASSERT_EQ(summary.files.size(), 2u);

  const auto gpkg = Open(dir / "trees.gpkg");
  ASSERT_TRUE(gpkg);
  ASSERT_EQ(gpkg->GetLayerCount(), 3);
  OGRLayer* trees = gpkg->GetLayerByName("trees");
  ASSERT_NE(trees, nullptr);
  OGRSpatialReference utm30;
  utm30.importFromEPSG(25830);
  EXPECT_TRUE(trees->GetSpatialRef()->IsSame(&utm30));
  ASSERT_EQ(trees->GetFeatureCount(), 3);
  int i = 0;
  for (const auto& f : *trees) {
    const OGRPoint* p = f->GetGeometryRef()->toPoint();
    const Eigen::Vector2d en = EastNorthByContract(33.0, stems[i].centre_xy);
    EXPECT_LT(std::hypot(p->getX() - 545000.0 - en.x(), p->getY() - 4700000.0 - en.y()), 0.01);
    EXPECT_EQ(f->GetFieldAsInteger("tree_id"), i + 1);
    EXPECT_NEAR(f->GetFieldAsDouble("dbh_cm"), 100 * stems[i].dbh_m, 1e-9);
    EXPECT_NEAR(f->GetFieldAsDouble("easting_m"), p->getX(), 1e-6);
    EXPECT_FALSE(f->IsFieldNull(f->GetFieldIndex("lat")));
    ++i;
  }
  OGRLayer* plot = gpkg->GetLayerByName("plot");
  ASSERT_NE(plot, nullptr);
  const auto circle = std::unique_ptr<OGRFeature>(plot->GetNextFeature());
  // A 10-m circle: π·100 m² less the one-degree chords' sliver.
  EXPECT_NEAR(circle->GetGeometryRef()->toPolygon()->get_Area(), M_PI * 100, 0.02);
  ASSERT_NE(gpkg->GetLayerByName("camera_path"), nullptr);
  EXPECT_EQ(gpkg->GetLayerByName("camera_path")->GetFeatureCount(), 1);

  // The GeoJSON in WGS 84: back to the CRS, each tree is where the GeoPackage has it.
  const auto geojson = Open(dir / "trees.geojson");
  ASSERT_TRUE(geojson);
  OGRLayer* layer = geojson->GetLayer(0);
  OGRSpatialReference wgs84;
  wgs84.SetWellKnownGeogCS("WGS84");
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  utm30.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::unique_ptr<OGRCoordinateTransformation> to_utm(
      OGRCreateCoordinateTransformation(&wgs84, &utm30));
  i = 0;
  for (const auto& f : *layer) {
    const OGRPoint* p = f->GetGeometryRef()->toPoint();
    double x = p->getX(), y = p->getY();
    ASSERT_TRUE(to_utm->Transform(1, &x, &y));
    const Eigen::Vector2d en = EastNorthByContract(33.0, stems[i].centre_xy);
    EXPECT_LT(std::hypot(x - 545000.0 - en.x(), y - 4700000.0 - en.y()), 0.01);
    ++i;
  }
  EXPECT_EQ(i, 3);
}

TEST(GisFiles, AWgs84CentreGivesTreesAtTheirGeodesicDistanceAndBearing) {
  const fs::path dir = GisDir("wgs84");
  GeoreferenceOptions o;
  o.centre_lat_deg = 42.31;
  o.centre_lon_deg = -2.52;
  o.first_bearing_deg = 300.0;
  o.declination_deg = 1.0;
  const Georeference georef(o);
  const std::vector<stems::Stem> stems = SomeStems();
  const std::vector<TreeRow> rows = TreeRows({}, stems, georef);
  WriteGisFiles(georef, {&rows, {}, 10.0}, dir);
  geod_geodesic ellipsoid;
  geod_init(&ellipsoid, 6378137.0, 1 / 298.257223563);
  for (const char* name : {"trees.gpkg", "trees.geojson"}) {
    const auto ds = Open(dir / name);
    ASSERT_TRUE(ds) << name;
    OGRLayer* trees = ds->GetLayerByName("trees");
    ASSERT_NE(trees, nullptr) << name;
    int i = 0;
    for (const auto& f : *trees) {
      const OGRPoint* p = f->GetGeometryRef()->toPoint();
      double distance_m = 0, azimuth_deg = 0, back = 0;
      geod_inverse(&ellipsoid, 42.31, -2.52, p->getY(), p->getX(), &distance_m, &azimuth_deg,
                   &back);
      const Eigen::Vector2d en = EastNorthByContract(301.0, stems[i].centre_xy);
      const Eigen::Vector2d at =
          distance_m * Eigen::Vector2d(std::sin(azimuth_deg * kDeg), std::cos(azimuth_deg * kDeg));
      EXPECT_LT((at - en).norm(), 0.01) << name << " tree " << i + 1;
      EXPECT_NEAR(f->GetFieldAsDouble("bearing_deg"), rows[i].bearing_deg.value(), 1e-9);
      ++i;
    }
    EXPECT_EQ(i, 3) << name;
  }
}

TEST(GisFiles, WithoutACentreTheGeoPackageIsInALocalFrameAndNoGeoJsonIsWritten) {
  const fs::path dir = GisDir("local");
  const Georeference georef(GeoreferenceOptions{});
  const std::vector<stems::Stem> stems = SomeStems();
  const std::vector<TreeRow> rows = TreeRows({}, stems, georef);
  const GisSummary summary = WriteGisFiles(georef, {&rows, {}, 10.0}, dir);
  EXPECT_EQ(summary.files.size(), 1u);
  EXPECT_FALSE(fs::exists(dir / "trees.geojson"));
  const auto gpkg = Open(dir / "trees.gpkg");
  ASSERT_TRUE(gpkg);
  OGRLayer* trees = gpkg->GetLayerByName("trees");
  ASSERT_NE(trees, nullptr);
  ASSERT_NE(trees->GetSpatialRef(), nullptr);
  EXPECT_TRUE(trees->GetSpatialRef()->IsLocal());
  const auto first = std::unique_ptr<OGRFeature>(trees->GetNextFeature());
  EXPECT_NEAR(first->GetGeometryRef()->toPoint()->getX(), 3.0, 1e-9);
  EXPECT_TRUE(first->IsFieldNull(first->GetFieldIndex("bearing_deg")));
  EXPECT_TRUE(first->IsFieldNull(first->GetFieldIndex("lon")));
}

TEST(GisFiles, TheSameInputGivesTheSameBytes) {
  GeoreferenceOptions o;
  o.centre_lat_deg = 42.31;
  o.centre_lon_deg = -2.52;
  o.first_bearing_deg = 10.0;
  const Georeference georef(o);
  const std::vector<TreeRow> rows = TreeRows({}, SomeStems(), georef);
  const fs::path a = GisDir("same_a"), b = GisDir("same_b");
  WriteGisFiles(georef, {&rows, {{1.0, 0.0}, {0.0, 1.0}}, 10.0}, a);
  WriteGisFiles(georef, {&rows, {{1.0, 0.0}, {0.0, 1.0}}, 10.0}, b);
  for (const char* name : {"trees.gpkg", "trees.geojson"}) {
    EXPECT_EQ(ReadFileToString(a / name), ReadFileToString(b / name)) << name;
  }
  // Nothing but the files: no temporary left behind.
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(a)) ++entries;
  EXPECT_EQ(entries, 2);
}

}  // namespace
}  // namespace stemmap::gis
