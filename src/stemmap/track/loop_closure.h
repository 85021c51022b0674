#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <vector>

#include "stemmap/camera/camera.h"
#include "stemmap/track/frontend.h"

namespace stemmap::track {

struct LoopOptions {
  double ratio = 0.8;           // Lowe's ratio test on ORB matches
  double threshold_deg = 0.35;  // rotation-only inlier threshold
  int min_inliers = 25;
  double min_inlier_share = 0.3;
  double search_min_turn = 0.85;  // revisit searched from 0.85 to 1.5 apparent turns
  double search_max_turn = 1.5;
  double merge_radius_px = 2.5;  // ORB keypoint to KLT observation
  void Check() const;
};
// Every option, to save beside the outputs and read back (`--options FILE`); a missing key keeps
// its default.
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(LoopOptions, ratio, threshold_deg, min_inliers,
                                                min_inlier_share, search_min_turn, search_max_turn,
                                                merge_radius_px)

// A verified revisit: keyframe `late` sees what keyframe `early` saw one turn before.
struct LoopPair {
  int early = 0, late = 0;
  int inliers = 0;
  double yaw_rad = 0.0;  // left turn of `late` relative to `early`, modulo a full turn
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> matches;  // (early px, late px)
};

struct LoopResult {
  std::vector<LoopPair> pairs;
  // Apparent cumulative turn (rad) over one true full turn: the factor that maps apparent turn
  // angles onto true ones (>= 1 when parallax inflates the apparent motion).
  double apparent_per_turn_rad = 0.0;
  int merged_tracks = 0;
  int extended_tracks = 0;
};

// Verifies one keyframe pair; returns false when it is not a revisit.
bool VerifyLoopPair(const LoopOptions& o, const Keyframe& early, const Keyframe& late,
                    const PinholeCamera& camera, int early_index, int late_index, LoopPair* pair);

// Finds the revisits after one turn. `apparent_turn_rad` is the cumulative apparent turn per
// keyframe. Returns no pairs when the video holds no revisit.
LoopResult FindLoops(const LoopOptions& o, const FrontendResult& f, const PinholeCamera& camera,
                     const std::vector<double>& apparent_turn_rad);

// Joins tracks that the loop matches show to be the same point, so bundle adjustment sees the
// revisit as shared landmarks. Updates `f.tracks` and the counts in `loop`.
void MergeLoopTracks(const LoopOptions& o, FrontendResult& f, LoopResult& loop);

}  // namespace stemmap::track
