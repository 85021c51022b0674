#include "stemmap/gis/gis_files.h"

#include <cpl_conv.h>
#include <fmt/format.h>
#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include <cmath>
#include <mutex>
#include <string>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::gis {

namespace {

namespace fs = std::filesystem;

void RegisterGdalOnce() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

// The last GDAL error as a sentence, for our one-line messages.
std::string GdalError() {
  const char* msg = CPLGetLastErrorMsg();
  return msg && *msg ? msg : "unknown GDAL error";
}

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};
using Dataset = std::unique_ptr<GDALDataset, DatasetCloser>;

Dataset Create(const char* driver_name, const fs::path& path) {
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName(driver_name);
  if (!driver) throw ProcessingError(fmt::format("GDAL has no {} driver", driver_name));
  Dataset ds(driver->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
  if (!ds) throw InputError(fmt::format("cannot write {}: {}", path.string(), GdalError()));
  return ds;
}

OGRLayer* CreateLayer(GDALDataset* ds, const char* name, const OGRSpatialReference& srs,
                      OGRwkbGeometryType type, CSLConstList options) {
  OGRLayer* layer = ds->CreateLayer(name, const_cast<OGRSpatialReference*>(&srs), type,
                                    const_cast<char**>(options));
  if (!layer) throw ProcessingError(fmt::format("cannot create layer {}: {}", name, GdalError()));
  return layer;
}

void AddField(OGRLayer* layer, const char* name, OGRFieldType type) {
  OGRFieldDefn field(name, type);
  if (layer->CreateField(&field) != OGRERR_NONE) {
    throw ProcessingError(fmt::format("cannot add field {}: {}", name, GdalError()));
  }
}

void AddFeature(OGRLayer* layer, OGRFeature* feature) {
  if (layer->CreateFeature(feature) != OGRERR_NONE) {
    throw ProcessingError(fmt::format("cannot write a feature: {}", GdalError()));
  }
}

// A point feature at (x, y), its fields set by `set_fields(OGRFeature&)`.
template <typename SetFields>
void AddPoint(OGRLayer* layer, double x, double y, SetFields set_fields) {
  OGRFeature feature(layer->GetLayerDefn());
  set_fields(feature);
  OGRPoint point(x, y);
  feature.SetGeometry(&point);
  AddFeature(layer, &feature);
}

// The trees layer: every trees.csv column, in its order, on points at `gis_xy`.
void WriteTreesLayer(GDALDataset* ds, const OGRSpatialReference& srs,
                     const std::vector<TreeRow>& rows, const std::vector<Eigen::Vector2d>& gis_xy,
                     CSLConstList layer_options) {
  OGRLayer* layer = CreateLayer(ds, "trees", srs, wkbPoint, layer_options);
  AddField(layer, "tree_id", OFTInteger);
  for (const char* name : {"x_m", "y_m", "z_m", "dbh_cm", "dbh_sd_cm", "distance_m", "azimuth_deg",
                           "bearing_deg", "easting_m", "northing_m", "lat", "lon"}) {
    AddField(layer, name, OFTReal);
  }
  AddField(layer, "n_views", OFTInteger);
  AddField(layer, "confidence", OFTReal);
  AddField(layer, "flags", OFTString);
  for (size_t i = 0; i < rows.size(); ++i) {
    const TreeRow& r = rows[i];
    OGRFeature feature(layer->GetLayerDefn());
    feature.SetField("tree_id", r.tree_id);
    feature.SetField("x_m", r.xy_m.x());
    feature.SetField("y_m", r.xy_m.y());
    feature.SetField("z_m", r.z_m);
    feature.SetField("dbh_cm", r.dbh_cm);
    feature.SetField("dbh_sd_cm", r.dbh_sd_cm);
    feature.SetField("distance_m", r.distance_m);
    feature.SetField("azimuth_deg", r.azimuth_deg);
    auto set_optional = [&](const char* name, const std::optional<double>& v) {
      if (v) {
        feature.SetField(name, *v);
      } else {
        feature.SetFieldNull(feature.GetFieldIndex(name));
      }
    };
    set_optional("bearing_deg", r.bearing_deg);
    const std::optional<MapPoint>& m = r.map;
    set_optional("easting_m", m ? std::optional(m->easting_m) : std::nullopt);
    set_optional("northing_m", m ? std::optional(m->northing_m) : std::nullopt);
    set_optional("lat", m ? std::optional(m->lat_deg) : std::nullopt);
    set_optional("lon", m ? std::optional(m->lon_deg) : std::nullopt);
    feature.SetField("n_views", r.n_views);
    feature.SetField("confidence", r.confidence);
    feature.SetField("flags", r.flags.c_str());
    OGRPoint point(gis_xy[i].x(), gis_xy[i].y());
    feature.SetGeometry(&point);
    AddFeature(layer, &feature);
  }
}

void WritePlotLayer(GDALDataset* ds, const Georeference& georef, double radius_m) {
  OGRLayer* layer = CreateLayer(ds, "plot", georef.GisCrs(), wkbPolygon, nullptr);
  AddField(layer, "radius_m", OFTReal);
  // One vertex a degree: the chord falls short of the circle by under 0.4 mm at 10 m.
  std::vector<Eigen::Vector2d> circle;
  for (int i = 0; i < 360; ++i) {
    const double a = i * M_PI / 180.0;
    circle.emplace_back(radius_m * std::cos(a), radius_m * std::sin(a));
  }
  circle.push_back(circle.front());
  OGRLinearRing ring;
  for (const Eigen::Vector2d& p : georef.GisXy(circle)) ring.addPoint(p.x(), p.y());
  OGRPolygon polygon;
  polygon.addRing(&ring);
  OGRFeature feature(layer->GetLayerDefn());
  feature.SetField("radius_m", radius_m);
  feature.SetGeometry(&polygon);
  AddFeature(layer, &feature);
}

void WriteCameraPathLayer(GDALDataset* ds, const Georeference& georef,
                          const std::vector<Eigen::Vector2d>& path_xy) {
  OGRLayer* layer = CreateLayer(ds, "camera_path", georef.GisCrs(), wkbLineString, nullptr);
  if (path_xy.size() < 2) return;
  OGRLineString line;
  for (const Eigen::Vector2d& p : georef.GisXy(path_xy)) line.addPoint(p.x(), p.y());
  OGRFeature feature(layer->GetLayerDefn());
  feature.SetGeometry(&line);
  AddFeature(layer, &feature);
}

// Writes into a temporary file beside `path` (keeping its extension, which GDAL's drivers look
// at) and renames it over `path` once the dataset is closed.
template <typename Fill>
void WriteDatasetAtomic(const char* driver, const fs::path& path, Fill fill) {
  fs::create_directories(path.parent_path());
  fs::path tmp = TempPathFor(path);
  tmp += path.extension();
  try {
    Dataset ds = Create(driver, tmp);
    fill(ds.get());
    // GDAL 3.6's GDALClose returns nothing: a failure to finish the file shows as the last error.
    CPLErrorReset();
    GDALClose(ds.release());
    if (CPLGetLastErrorType() >= CE_Failure) {
      throw InputError(fmt::format("cannot write {}: {}", path.string(), GdalError()));
    }
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
  CommitTempFile(tmp, path);
}

// Sets a GDAL configuration option for this thread while in scope.
class ScopedConfig {
 public:
  ScopedConfig(const char* key, const char* value) : key_(key) {
    CPLSetThreadLocalConfigOption(key, value);
  }
  ~ScopedConfig() { CPLSetThreadLocalConfigOption(key_, nullptr); }
  ScopedConfig(const ScopedConfig&) = delete;
  ScopedConfig& operator=(const ScopedConfig&) = delete;

 private:
  const char* key_;
};

}  // namespace

GisSummary WriteGisFiles(const Georeference& georef, const GisInput& in, const fs::path& out_dir) {
  RegisterGdalOnce();
  // The GeoPackage records a "last change" time; a fixed one keeps the file the same for the same
  // input.
  ScopedConfig date("OGR_CURRENT_DATE", "2000-01-01T00:00:00.000Z");
  std::vector<Eigen::Vector2d> tree_xy;
  for (const TreeRow& r : *in.trees) tree_xy.push_back(r.xy_m);
  const std::vector<Eigen::Vector2d> gis_xy = georef.GisXy(tree_xy);
  GisSummary summary;
  const fs::path gpkg = out_dir / "trees.gpkg";
  WriteDatasetAtomic("GPKG", gpkg, [&](GDALDataset* ds) {
    ds->StartTransaction();
    WriteTreesLayer(ds, georef.GisCrs(), *in.trees, gis_xy, nullptr);
    WritePlotLayer(ds, georef, in.plot_radius_m);
    WriteCameraPathLayer(ds, georef, in.camera_path_xy);
    if (ds->CommitTransaction() != OGRERR_NONE) {
      throw InputError(fmt::format("cannot write {}: {}", gpkg.string(), GdalError()));
    }
  });
  summary.files.push_back(gpkg);
  if (georef.HasCentre()) {
    std::vector<Eigen::Vector2d> lon_lat;
    for (const TreeRow& r : *in.trees) lon_lat.emplace_back(r.map->lon_deg, r.map->lat_deg);
    OGRSpatialReference wgs84;
    wgs84.SetWellKnownGeogCS("WGS84");
    wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    // 9 decimals of a degree: 0.1 mm, so the file keeps the centimetre the contract promises.
    const char* options[] = {"RFC7946=YES", "COORDINATE_PRECISION=9", "WRITE_NAME=NO", nullptr};
    const fs::path geojson = out_dir / "trees.geojson";
    WriteDatasetAtomic("GeoJSON", geojson, [&](GDALDataset* ds) {
      WriteTreesLayer(ds, wgs84, *in.trees, lon_lat, options);
    });
    summary.files.push_back(geojson);
  }
  return summary;
}

void WriteInventoryGeoPackage(const fs::path& path, const std::vector<InventoryPlot>& plots,
                              const std::vector<InventoryTree>& trees) {
  RegisterGdalOnce();
  ScopedConfig date("OGR_CURRENT_DATE", "2000-01-01T00:00:00.000Z");
  OGRSpatialReference wgs84;
  wgs84.SetWellKnownGeogCS("WGS84");
  wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  WriteDatasetAtomic("GPKG", path, [&](GDALDataset* ds) {
    ds->StartTransaction();
    OGRLayer* p = CreateLayer(ds, "plots", wgs84, wkbPoint, nullptr);
    AddField(p, "plot_id", OFTString);
    AddField(p, "stems", OFTInteger);
    for (const char* name : {"stems_per_ha", "basal_area_m2_per_ha", "qmd_cm"}) {
      AddField(p, name, OFTReal);
    }
    for (const InventoryPlot& plot : plots) {
      AddPoint(p, plot.lon_deg, plot.lat_deg, [&](OGRFeature& f) {
        f.SetField("plot_id", plot.plot_id.c_str());
        f.SetField("stems", plot.stems);
        f.SetField("stems_per_ha", plot.stems_per_ha);
        f.SetField("basal_area_m2_per_ha", plot.basal_area_m2_per_ha);
        f.SetField("qmd_cm", plot.qmd_cm);
      });
    }
    OGRLayer* t = CreateLayer(ds, "trees", wgs84, wkbPoint, nullptr);
    AddField(t, "plot_id", OFTString);
    AddField(t, "tree_id", OFTInteger);
    AddField(t, "dbh_cm", OFTReal);
    AddField(t, "dbh_sd_cm", OFTReal);
    for (const InventoryTree& tree : trees) {
      AddPoint(t, tree.lon_deg, tree.lat_deg, [&](OGRFeature& f) {
        f.SetField("plot_id", tree.plot_id.c_str());
        f.SetField("tree_id", tree.tree_id);
        f.SetField("dbh_cm", tree.dbh_cm);
        f.SetField("dbh_sd_cm", tree.dbh_sd_cm);
      });
    }
    if (ds->CommitTransaction() != OGRERR_NONE) {
      throw InputError(fmt::format("cannot write {}: {}", path.string(), GdalError()));
    }
  });
}

}  // namespace stemmap::gis
