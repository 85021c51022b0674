#pragma once

// The fused cloud as LAS 1.4 (point data record format 7: coordinates, RGB and GPS time), the
// format CloudCompare, PDAL, lidR and GIS software read.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "stemmap/dense/stereo.h"
#include "stemmap/gis/georef.h"

namespace stemmap::gis {

struct LasPoint {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();  // in the file's CRS, after scale and offset
  uint16_t red = 0, green = 0, blue = 0;          // 16 bits a channel
  uint16_t point_source_id = 0;                   // the keyframe that measured the point
  double gps_time = 0.0;                          // that keyframe's time in the video (s)
};

struct LasFile {
  std::string system_identifier, generating_software;
  uint8_t point_format = 0;
  Eigen::Vector3d scale = Eigen::Vector3d::Zero(), offset = Eigen::Vector3d::Zero();
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  std::string wkt;  // the CRS (OGC WKT VLR); empty if none
  std::vector<LasPoint> points;
};

// Writes the cloud atomically to `path`: x, y as `georef` places the plot on the map (the
// projected CRS with a plot centre, else the local frame of the GIS files), z in the plot frame
// (height above the ground at the plot centre), millimetre resolution, colours scaled to 16 bits,
// each point's keyframe as its point source ID and that keyframe's time (`keyframe_t_s`, seconds
// in the video) as its GPS time; the CRS as an OGC WKT VLR.
void WriteLas(const std::filesystem::path& path, const std::vector<dense::CloudPoint>& points,
              const std::vector<double>& keyframe_t_s, const Georeference& georef);

// Reads a LAS 1.4 file of point format 7 (as WriteLas writes). Anything else, or a short or
// damaged file, is an InputError naming the file.
LasFile ReadLas(const std::filesystem::path& path);

}  // namespace stemmap::gis
