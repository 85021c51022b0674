#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <nlohmann/json.hpp>
#include <vector>

#include "stemmap/dense/stereo.h"

namespace stemmap::stems {

struct GroundOptions {
  double cell_m = 0.5;      // grid cell (m)
  int min_cell_points = 8;  // fewer points: the cell is not measured
  // A cell's floor is the lowest layer (floor_bin_m thick) that holds at least floor_min_points
  // of its points (a stray stereo point below the ground does not; leaves and a stem's bark
  // outnumber the ground in their cells, so no quantile of the cell would do). Its ground is the
  // median of its points within ground_layer_m above the floor.
  double floor_bin_m = 0.05;
  int floor_min_points = 3;
  double ground_layer_m = 0.1;
  // Within ~4 m of the tripod the outward-facing camera sees no ground: the lowest thing a cell
  // shows there (a stem's bark, a shrub) is where the frame's bottom edge cut the view, and the
  // ground lies somewhere below it. A cell whose floor (its lowest floor_bin_m) holds more than
  // this share of points seen at their view's bottom edge (CloudPoint::at_view_bottom) is not
  // measured: its ground comes from the ground cells around it.
  double max_floor_at_view_bottom = 0.5;
  // A cell under whose floor at least min_rays_under_floor rays passed, more than
  // max_pass_under_floor_m below it, on to what lies beyond (short of the last
  // pass_end_clearance_m of each, where depth noise puts points past their surface), is not
  // measured either: the camera saw under what it shows there (a shrub's leaves, a sapling's
  // crown), so the ground lies lower still. 0 rays: no such test.
  int min_rays_under_floor = 3;
  double max_pass_under_floor_m = 0.1;
  double pass_end_clearance_m = 0.5;
  // Morphological ground filter (progressive opening): windows of these diameters (m), growing;
  // a cell standing more than min_rise_m + max_slope times the window's radius above the opened
  // surface is something on the ground (shrub, sapling crown, dead wood, a stem's part), not it.
  // Slopes, and mounds broader than the window, stay ground.
  std::vector<double> windows_m = {1.0, 2.0, 4.0, 8.0};
  double min_rise_m = 0.05;
  double max_slope = 0.3;  // rise over run (17°)
  // Cells without ground (under the tripod the outward-facing camera sees none within ~3.5 m;
  // under a wide shrub) take the plane through the ground cells within this (m), weighted by
  // inverse squared distance, else the plane through all ground cells.
  double fill_radius_m = 5.0;
  // Where the ground cells' centre (weighted as above) lies farther than fill_one_sided_m from
  // the cell, all on one side (under the tripod, 3-6 m from the ground seen), the local slope
  // leans on the plot's with the weight of fill_slope_prior ground cells around: the slope of a
  // few cells on one side, tilted by their bumps, would put a near stem's ground 10-30 cm off.
  double fill_one_sided_m = 2.5;
  double fill_slope_prior = 10.0;
  // The ground under the tripod (AxisHeight) is the plane through the ground cells within this
  // (m): nearer ones alone, seen from 3.5 m out, would carry a mound beside the tripod into it.
  double axis_plane_radius_m = 8.0;
  // A cell's floor is an extreme of its points' depth noise (the lower the more points it
  // holds), and on a slope its ground layer holds the cell's downhill part only: both put the
  // ground centimetres low. So each ground cell is then moved by the median height of its points
  // from refine_below_m under the grid's surface to refine_above_m over it (m; bilinear between
  // cells, so a slope within the cell is no bias), refine_iterations times. The band reaches less
  // far up: what stands on the ground (leaves, litter, a stem's foot) is above it, never under. 0
  // iterations (the default): floors as they are. On this project's simulated natural plots three
  // iterations bring the ground at stems from 1.7 cm low to 0.7 cm; on the other renderer's
  // sample, whose floor is covered with litter a few centimetres deep, they read it 2.7 cm higher
  // than its floors do and put fewer stems within 5 cm (docs/benchmarks.md).
  double refine_below_m = 0.1;
  double refine_above_m = 0.05;
  int refine_iterations = 0;
  void Check() const;
};
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(
    GroundOptions, cell_m, min_cell_points, floor_bin_m, floor_min_points, ground_layer_m,
    max_floor_at_view_bottom, min_rays_under_floor, max_pass_under_floor_m, pass_end_clearance_m,
    windows_m, min_rise_m, max_slope, fill_radius_m, fill_one_sided_m, fill_slope_prior,
    axis_plane_radius_m, refine_below_m, refine_above_m, refine_iterations)

// Terrain under the plot: a grid of ground heights from each cell's floor, with what stands on
// the ground (shrubs, sapling crowns, dead wood) filtered out by a progressive morphological
// opening, islands apart from the ground's largest patch left out, and holes filled from the
// ground cells around them. Heights above ground follow a
// slope, its bumps and mounds.
class GroundGrid {
 public:
  GroundGrid() = default;
  // `points` in the plot frame; cells out to `radius_m` from the plot centre.
  GroundGrid(const std::vector<dense::CloudPoint>& points, double radius_m,
             const GroundOptions& options = {});
  double Height(double x, double y) const { return Interpolate(z_, x, y); }
  // The grid before its cells were centred on their points (GroundOptions::refine_iterations):
  // each at the median of its floor layer, centimetres low on dense, noisy or sloping ground.
  // Detection measures heights above this one: what stands on the ground is told apart from it
  // there, and the bands' limits were set on it.
  double FloorHeight(double x, double y) const { return Interpolate(floor_z_, x, y); }
  // The ground on the uphill side of a stem of `radius_m` standing at (x, y): the highest of the
  // ground at its axis and around its girth. On a slope, breast height is measured from there.
  double UphillHeight(double x, double y, double radius_m) const;
  // The ground under the plot centre, where the camera sees none (GroundOptions::
  // axis_plane_radius_m); NaN without three ground cells in reach.
  double AxisHeight() const { return axis_height_m_; }
  bool empty() const { return n_ == 0; }
  // The plane through the grid's ground within `radius_m` of the plot centre (least squares over
  // the cell centres): its steepest slope (degrees) and the azimuth it falls toward (degrees,
  // counter-clockwise from x). {0, 0} for an empty grid.
  struct Slope {
    double slope_deg = 0.0, downhill_azimuth_deg = 0.0;
  };
  Slope PlaneSlope(double radius_m) const;
  int measured_cells() const { return measured_; }  // cells with points
  int ground_cells() const { return ground_; }      // of which on the ground

 private:
  // Marks the cells the camera saw under (GroundOptions::min_rays_under_floor) not measured.
  void DropFloorsSeenUnder(const std::vector<dense::CloudPoint>& points,
                           std::vector<float>* floors);
  // The ground flag of each measured cell from the floors (NaN: not measured).
  std::vector<char> FilterGround(const std::vector<float>& floors) const;
  void KeepTheLargestGroundPatch(const std::vector<float>& floors,
                                 std::vector<char>* is_ground) const;
  // Heights of the cells off the ground from the ground cells around them.
  void FillFromGroundCells(const std::vector<char>& is_ground);
  // The index of the cell holding (x, y), or -1 outside the grid.
  std::ptrdiff_t CellOf(double x, double y) const;
  // Bilinear between cell centres.
  double Interpolate(const std::vector<float>& z, double x, double y) const;
  // Moves each ground cell to its points about the surface (GroundOptions::refine_*).
  void CentreOnPoints(const std::vector<dense::CloudPoint>& points,
                      const std::vector<char>& is_ground);
  GroundOptions o_;
  int n_ = 0, measured_ = 0, ground_ = 0;
  double origin_ = 0.0, axis_height_m_ = 0.0;
  std::vector<float> z_, floor_z_;
};

}  // namespace stemmap::stems
