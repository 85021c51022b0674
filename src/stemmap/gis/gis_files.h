#pragma once

// The tree list for GIS software: a GeoPackage and, with a plot centre, a GeoJSON file (GDAL).
#include <Eigen/Core>
#include <filesystem>
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

}  // namespace stemmap::gis
