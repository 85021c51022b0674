#pragma once

// How far to trust each stem: the SD of its DBH and the chance that it is a stem at all, from
// what measured it. The constants are measured on the tuning plots (seeds 1-5 of both kinds,
// docs/benchmarks.md), not on the plots the benchmark judges.
#include <nlohmann/json.hpp>

#include "stemmap/stems/stems.h"

namespace stemmap::stems {

struct UncertaintyOptions {
  // A DBH's SD adds in quadrature the silhouette fit's own spread (over views) and what does not
  // average out over views:
  double edge_bias_px = 0.5;     // each silhouette's bias, px at the stem (blur, bark relief)
  double section_share = 0.015;  // of the DBH: a section not round, read from one arc of views
  // Where the silhouettes' width and the cloud's both exist, this share of their gap: a gap
  // says one of them caught something else.
  double estimator_gap_share = 0.5;
  // And, for a width that rests on less, these shares of the DBH:
  double one_sided_share = 0.08;      // one side seen in most views (StemFlag::kOneSided)
  double occluded_share = 0.04;       // many silhouettes beside a nearer stem
  double no_silhouette_share = 0.15;  // the cloud's width alone: part of the stem may be hidden
  double depth_smeared_share = 0.04;  // the points were smeared along the line of sight
  double few_views_share = 0.04;
  // The share of listed stems that were stems on the tuning plots, by what listed them: a
  // silhouette fit two-sided in three views or more; one-sided; the cloud's width alone; the
  // silhouettes alone where the cloud had no part.
  double confidence_two_sided = 0.99;
  double confidence_one_sided = 0.95;
  double confidence_cloud_only = 0.9;
  double confidence_silhouette_only = 0.85;
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
