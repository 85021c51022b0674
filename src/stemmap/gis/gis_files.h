#pragma once

// The tree list for GIS software: a GeoPackage and, with a plot centre, a GeoJSON file (GDAL).
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "stemmap/gis/georef.h"
#include "stemmap/gis/tree_table.h"

namespace stemmap::gis {

struct GisInput {
  const std::vector<TreeRow>* trees = nullptr;
  std::vector<Eigen::Vector2d> camera_path_xy;  // camera centres, plot frame
  double plot_radius_m = 10.0;
};

struct GisSummary {
  std::vector<std::filesystem::path> files;  // written, in order
};

// OUT/trees.gpkg with the layers `trees` (points with every trees.csv column), `plot` (the plot
// circle) and `camera_path` (line), in `georef.GisCrs()`; with a plot centre also
// OUT/trees.geojson (RFC 7946: WGS 84 longitude, latitude) with the trees. Written atomically and
// byte for byte the same for the same input.
GisSummary WriteGisFiles(const Georeference& georef, const GisInput& input,
                         const std::filesystem::path& out_dir);

// Many plots in one GeoPackage (`stemmap batch`), WGS 84: layer `plots` (each plot's centre with
// its figures) and layer `trees` (every tree of those plots, with its plot_id).
struct InventoryPlot {
  std::string plot_id;
  double lat_deg = 0.0, lon_deg = 0.0;
  int stems = 0;
  double stems_per_ha = 0.0, basal_area_m2_per_ha = 0.0, qmd_cm = 0.0;
};
struct InventoryTree {
  std::string plot_id;
  int tree_id = 0;
  double lat_deg = 0.0, lon_deg = 0.0;
  double dbh_cm = 0.0, dbh_sd_cm = 0.0;
};
void WriteInventoryGeoPackage(const std::filesystem::path& path,
                              const std::vector<InventoryPlot>& plots,
                              const std::vector<InventoryTree>& trees);

}  // namespace stemmap::gis
