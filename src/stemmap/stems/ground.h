#pragma once

#include <Eigen/Core>
#include <vector>

#include "stemmap/dense/stereo.h"

namespace stemmap::stems {

// Terrain under the plot: a grid of ground heights from the lowest points of each cell, holes
// filled from the neighbours, so heights above ground follow a slope and its bumps.
class GroundGrid {
 public:
  GroundGrid() = default;
  // `points` in the plot frame; cells of `cell_m` out to `radius_m`.
  GroundGrid(const std::vector<dense::CloudPoint>& points, double radius_m, double cell_m);
  double Height(double x, double y) const;
  bool empty() const { return n_ == 0; }
  int measured_cells() const { return measured_; }

 private:
  // Bumps stay; a cell this far above the plane through the terrain is not ground.
  static constexpr double kMaxAbovePlaneM = 0.35;
  void FitPlaneAndDropRaisedCells();
  Eigen::Vector3d plane_ = Eigen::Vector3d::Zero();  // z = a x + b y + c
  int n_ = 0, measured_ = 0;
  double cell_ = 0.5, origin_ = 0.0;
  std::vector<float> z_;
};

}  // namespace stemmap::stems
