#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "stemmap/stems/plot_figures.h"
#include "stemmap/stems/stems.h"

namespace stemmap::report {

struct MapOptions {
  double plot_radius_m = 10.0;
  int size_px = 640;
  // Stems are drawn this many times their DBH: at true scale a 10-cm stem is a dot.
  double stem_scale = 3.0;
  // Azimuth of true north in the plot frame (degrees counter-clockwise from x: the first bearing
  // plus the declination); when known the map is turned north up, with a north arrow and the
  // compass points.
  std::optional<double> north_azimuth_deg;
  void Check() const;
};

// Stem map of the plot as a standalone SVG: the plot circle, 2-m rings (labelled where no stem
// stands), the camera's path, the ground hidden behind stems shaded (`hidden`), every stem at its
// position (plot frame, x to the right, y up; north up when known) labelled with its tree_id
// (order in `stems`, as trees.csv) and linked to `#tree-N` (the report's row), flagged stems in
// orange, stems outside the plot radius in grey.
std::string PlotMapSvg(const MapOptions& options, const std::vector<stems::Stem>& stems,
                       const std::vector<Eigen::Vector2d>& camera_path_xy,
                       const std::vector<stems::HiddenSector>& hidden = {});

}  // namespace stemmap::report
