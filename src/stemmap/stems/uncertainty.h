#pragma once

// How far to trust each stem: the SD of its DBH and the chance that it is a stem at all, from
// what measured it. The constants are measured on the tuning plots (managed seeds 1-5 and natural
// seeds 1-2 at 15 fps, docs/benchmarks.md), not on the plots the benchmark judges.
#include <nlohmann/json.hpp>

#include "stemmap/stems/stems.h"

namespace stemmap::stems {

struct UncertaintyOptions {
  // A DBH's SD adds in quadrature the silhouette fit's own spread (over views) and what does not
  // average out over views. Measured on the tuning plots (bench/fit_uncertainty.py: the smallest
  // mean SD that covers 95 % of the unflagged stems' errors within ±2 SD, then for each flag the
  // smallest share that covers 95 % of its stems; a flag no tuning stem carried keeps a prior):
  double edge_bias_px = 0.25;    // each silhouette's bias, px at the stem (blur, bark relief)
  double section_share = 0.025;  // of the DBH: a section not round, read from one arc of views
  // Where the silhouettes' width and the cloud's both exist, this share of their gap: a gap
  // says one of them caught something else.
  double estimator_gap_share = 0.25;
  // And, for a width that rests on less, these shares of the DBH:
  double one_sided_share = 0.3;      // one side seen in most views (StemFlag::kOneSided)
  double occluded_share = 0.5;       // a nearer stem hides part of it: often read far too thin
  double no_silhouette_share = 0.5;  // the cloud's width alone: part of the stem may be hidden
  double depth_smeared_share = 0.0;  // the points were smeared along the line of sight
  double few_views_share = 0.04;     // (prior: no tuning stem carried it)
  // The chance that a listed stem is a stem, by what listed it: a silhouette fit two-sided in
  // three views or more; one-sided; the cloud's width alone; the silhouettes alone where the
  // cloud had no part. The rule of succession, (stems + 1) / (listed + 2), over the tuning plots'
  // listed stems (DBH >= 10 cm within 10 m): 89 of 89, 1 of 1, 3 of 3 and 1 of 1 were stems.
  double confidence_two_sided = 0.99;
  double confidence_one_sided = 0.67;
  double confidence_cloud_only = 0.8;
  double confidence_silhouette_only = 0.67;
  void Check() const;
};
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(UncertaintyOptions, edge_bias_px, section_share,
                                                estimator_gap_share, one_sided_share,
                                                occluded_share, no_silhouette_share,
                                                depth_smeared_share, few_views_share,
                                                confidence_two_sided, confidence_one_sided,
                                                confidence_cloud_only, confidence_silhouette_only)

// The SD of a listed stem's DBH (m). `silhouette_px_m`: one pixel's footprint at the stem in the
// images the silhouettes were found in.
double DbhSd(const UncertaintyOptions& options, const Stem& stem, double silhouette_px_m);

// The chance that a listed stem is a stem, from what listed it.
double DetectionConfidence(const UncertaintyOptions& options, const Stem& stem);

}  // namespace stemmap::stems
