#include "stemmap/gis/las.h"

#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::gis {
namespace {

namespace fs = std::filesystem;

fs::path LasDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("stemmap_las_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::vector<dense::CloudPoint> SomeCloud() {
  std::vector<dense::CloudPoint> cloud;
  for (int i = 0; i < 500; ++i) {
    dense::CloudPoint p;
    const double a = i * 0.37;
    p.world = Eigen::Vector3f(8.0f * std::cos(a), 8.0f * std::sin(a), 0.001f * i - 0.2f);
    p.origin = Eigen::Vector3f::Zero();
    p.bgr = cv::Vec3b(static_cast<uchar>(i % 256), 7, 255);
    p.keyframe = i % 9;
    cloud.push_back(p);
  }
  return cloud;
}

const std::vector<double> kKeyframeTimes = {0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0};

TEST(Las, AProjectedCentreGivesPointsInTheCrsToTheMillimetre) {
  const fs::path dir = LasDir("projected");
  GeoreferenceOptions o;
  o.centre_easting_m = 545000.0;
  o.centre_northing_m = 4700000.0;
  o.crs = "EPSG:25830";
  o.first_bearing_deg = 120.0;
  const Georeference georef(o);
  const std::vector<dense::CloudPoint> cloud = SomeCloud();
  WriteLas(dir / "cloud.las", cloud, kKeyframeTimes, georef);
  const LasFile f = ReadLas(dir / "cloud.las");
  EXPECT_EQ(f.point_format, 7);
  EXPECT_EQ(f.scale, Eigen::Vector3d::Constant(0.001));
  ASSERT_EQ(f.points.size(), cloud.size());
  OGRSpatialReference crs;
  ASSERT_EQ(crs.importFromWkt(f.wkt.c_str()), OGRERR_NONE);
  OGRSpatialReference utm30;
  utm30.importFromEPSG(25830);
  EXPECT_TRUE(crs.IsSame(&utm30));
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector2d xy = cloud[i].world.head<2>().cast<double>();
    const Eigen::Vector2d en = EastNorth(120.0, 0.0, xy);
    const LasPoint& p = f.points[i];
    EXPECT_NEAR(p.xyz.x(), 545000.0 + en.x(), 0.0006);
    EXPECT_NEAR(p.xyz.y(), 4700000.0 + en.y(), 0.0006);
    EXPECT_NEAR(p.xyz.z(), cloud[i].world.z(), 0.0006);
    EXPECT_EQ(p.red, cloud[i].bgr[2] * 257);
    EXPECT_EQ(p.blue, cloud[i].bgr[0] * 257);
    EXPECT_EQ(p.point_source_id, cloud[i].keyframe);
    EXPECT_EQ(p.gps_time, kKeyframeTimes[cloud[i].keyframe]);
    EXPECT_TRUE((p.xyz.array() >= f.min.array() - 1e-3).all());
    EXPECT_TRUE((p.xyz.array() <= f.max.array() + 1e-3).all());
  }
}

TEST(Las, WithoutACentreThePointsStayInThePlotFrame) {
  const fs::path dir = LasDir("local");
  const std::vector<dense::CloudPoint> cloud = SomeCloud();
  WriteLas(dir / "cloud.las", cloud, {}, Georeference(GeoreferenceOptions{}));
  const LasFile f = ReadLas(dir / "cloud.las");
  ASSERT_EQ(f.points.size(), cloud.size());
  EXPECT_NE(f.wkt.find("LOCAL_CS"), std::string::npos);
  EXPECT_LT((f.points[17].xyz - cloud[17].world.cast<double>()).norm(), 0.001);
  EXPECT_EQ(f.points[17].gps_time, 0.0);
}

TEST(Las, AnEmptyCloudIsAValidFile) {
  const fs::path dir = LasDir("empty");
  WriteLas(dir / "cloud.las", {}, {}, Georeference(GeoreferenceOptions{}));
  EXPECT_TRUE(ReadLas(dir / "cloud.las").points.empty());
}

TEST(Las, TheSameCloudGivesTheSameBytes) {
  const fs::path dir = LasDir("same");
  const Georeference georef(GeoreferenceOptions{});
  WriteLas(dir / "a.las", SomeCloud(), kKeyframeTimes, georef);
  WriteLas(dir / "b.las", SomeCloud(), kKeyframeTimes, georef);
  EXPECT_EQ(ReadFileToString(dir / "a.las"), ReadFileToString(dir / "b.las"));
}

TEST(Las, ADamagedFileIsAnInputError) {
  const fs::path dir = LasDir("damaged");
  WriteLas(dir / "cloud.las", SomeCloud(), {}, Georeference(GeoreferenceOptions{}));
  const std::string whole = ReadFileToString(dir / "cloud.las");
  for (const size_t keep : {size_t{0}, size_t{3}, size_t{200}, whole.size() - 5}) {
    WriteFileAtomic(dir / "cut.las", whole.substr(0, keep));
    EXPECT_THROW(ReadLas(dir / "cut.las"), InputError) << keep << " bytes";
  }
  std::string other = whole;
  other[25] = 2;  // version 1.2
  WriteFileAtomic(dir / "other.las", other);
  EXPECT_THROW(ReadLas(dir / "other.las"), InputError);
}

}  // namespace
}  // namespace stemmap::gis
