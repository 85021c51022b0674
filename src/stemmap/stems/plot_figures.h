#pragma once

// The plot figures foresters use (stems/ha, basal area/ha, QMD), each with a 95 % interval, and
// the ground the camera never saw past nearer stems, which hides stems the list cannot hold.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/core/pose.h"
#include "stemmap/stems/distance_sampling.h"
#include "stemmap/stems/interval.h"
#include "stemmap/stems/stems.h"

namespace stemmap::stems {

// Ground within the plot hidden behind one listed stem from every keyframe that looked its way.
struct HiddenSector {
  int tree = 0;                     // index of the stem in the list
  double azimuth_deg = 0.0;         // its bearing from the plot centre
  double half_width_deg = 0.0;      // of the hidden ground, about that bearing
  double from_m = 0.0, to_m = 0.0;  // distances from the plot centre
  double area_m2 = 0.0;
};

struct Visibility {
  std::vector<HiddenSector> sectors;  // nearest stems first
  double hidden_area_m2 = 0.0;        // within the plot radius
  double plot_area_m2 = 0.0;
};

// Which ground of the plot (radius `plot_radius_m`) no keyframe saw: a point is seen from a
// keyframe whose view holds it when no listed stem (a circle of its DBH at breast height) stands
// on the line between them. Sampled on a polar grid (0.1 m, 0.5°).
Visibility HiddenBehindStems(const std::vector<Stem>& trees,
                             const std::vector<StampedPose>& keyframes, const PinholeCamera& camera,
                             double plot_radius_m);

struct PlotFigureOptions {
  double plot_radius_m = 10.0;  // figures count stems within this radius (horizontal, centre rule)
  double min_dbh_cm = 7.0;      // and at least this thick
  int interval_draws = 4000;    // draws of the intervals' simulation
  uint64_t seed = 1;            // of those draws
  double class_width_cm = 5.0;  // of the stand table's DBH classes, which start at multiples of it
  // The dominant diameter is the quadratic mean DBH of this many thickest stems a hectare (the
  // plot's share of them, the last one weighted by its fraction).
  double dominant_stems_per_ha = 100.0;
  // The share of the stems in view that the detector lists (0.963 of the 567 stems at least half
  // visible on 46 fresh simulated plots, docs/benchmarks.md): each listed stem stands for
  // 1 / listed_share_in_view stems in view, and the intervals draw the others as missed stems
  // (their DBH from the listed ones). 1: every stem in view is listed.
  double listed_share_in_view = 0.96;
  OcclusionOptions occlusion;
  void Check() const;
};

// One row of the stand table: stems with from_cm <= DBH < to_cm.
struct DbhClass {
  double from_cm = 0.0, to_cm = 0.0;
  int stems = 0;
  double stems_per_ha = 0.0, basal_area_m2_per_ha = 0.0;
};

struct PlotFigures {
  int stems = 0;  // listed within the plot radius and at least the minimum DBH
  double stems_per_ha = 0.0, basal_area_m2_per_ha = 0.0, qmd_cm = 0.0;
  // 95 % intervals of the plot's true figures, drawing each listed stem's presence (its
  // confidence) and DBH (its SD), the stems in view the detector missed
  // (PlotFigureOptions::listed_share_in_view) and the stems the hidden ground holds at the
  // density of the ground seen (the DBH of both drawn from the listed ones).
  Interval stems_per_ha_95, basal_area_m2_per_ha_95, qmd_cm_95;
  double expected_hidden_stems = 0.0;
  double plot_area_m2 = 0.0;  // horizontal: distances are horizontal, so no slope correction
  std::vector<DbhClass> stand_table;  // thinnest class first, empty classes between kept
  double dominant_diameter_cm = 0.0;
  Interval dominant_diameter_cm_95;
  // Stems within one DBH of the plot edge (centre distance), listed or not; of them those whose
  // centre lies inside are counted, as the usual rule has it.
  int borderline_stems = 0, borderline_counted = 0;
  // Stems/ha and basal area corrected for the stems a scan from the centre misses, by distance
  // sampling (see distance_sampling.h), beside the figures of the list and of the hidden ground.
  OcclusionCorrection occlusion;
};

// The figures of `trees` (nearest first) for the plot; `visibility` gives the hidden ground.
PlotFigures ComputePlotFigures(const PlotFigureOptions& options, const std::vector<Stem>& trees,
                               const Visibility& visibility);

}  // namespace stemmap::stems
