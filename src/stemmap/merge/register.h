#pragma once

// Registration of two stem maps of one plot: the rotation and translation that put the stems of
// one run onto those of another, from the maps alone (no initial guess), robust to stems only
// one run found.
//
// Stems keep their DBH whatever the capture, and their distances to each other: every two pairs
// of stems of like DBH whose spacing agrees in both maps propose a transform (exhaustively, so
// the result does not depend on a random draw); the proposal that carries the most stems onto a
// stem of like DBH wins, and is refined by least squares on those stems (2-D Kabsch) until the
// matches settle.
#include <Eigen/Core>
#include <vector>

namespace stemmap::merge {

struct MapStem {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  // m, the run's plot frame
  double dbh_cm = 0.0;
};

struct RegisterOptions {
  double match_radius_m = 0.25;  // a moved stem matches a stem within this (m)
  // Stems match only when their DBH agree within this share of the larger, or dbh_slack_cm.
  double dbh_share = 0.2;
  double dbh_slack_cm = 3.0;
  double min_spacing_m = 1.0;  // a proposal needs its two stems at least this far apart (m)
  double spacing_tolerance_m = 0.15;
  int min_matches = 3;  // fewer stems matched: no registration
  // The matched stems' final fit weighs each by 1 / (1 + (d / robust_scale_m)^2), d its distance
  // after the transform (m; 0: plain least squares): stems agree to a few centimetres, and the
  // one a run placed a decimetre off must not drag the plot.
  double robust_scale_m = 0.03;
  void Check() const;
};

// `to_from_from`: a point of the `from` map in the `to` map's frame is rotation · p + translation.
struct Registration {
  bool ok = false;
  double yaw_deg = 0.0;
  Eigen::Vector2d translation_m = Eigen::Vector2d::Zero();
  std::vector<std::pair<int, int>> matches;  // (index in `to`, index in `from`)
  double rms_m = 0.0;                        // of the matched stems after the transform
  double matched_share = 0.0;                // matches / the smaller map's stems
  Eigen::Vector2d Apply(const Eigen::Vector2d& from_xy) const;
};

// Where both maps are placed on the earth (a GPS centre and a compass bearing each), the
// transform they imply, and how far from it a registration may lie: the GPS's and the compass's
// errors. A regular stand (a plantation's grid) registers almost as well one spacing off; the
// guess picks the right one.
struct RegistrationGuess {
  double yaw_deg = 0.0;
  Eigen::Vector2d translation_m = Eigen::Vector2d::Zero();
  double max_shift_m = 6.0;  // at the `from` map's centroid
  double max_turn_deg = 15.0;
};

// With a guess, only transforms within its bounds are proposed.
Registration RegisterMaps(const RegisterOptions& options, const std::vector<MapStem>& to,
                          const std::vector<MapStem>& from,
                          const RegistrationGuess* guess = nullptr);

// The rigid 2-D transform (least squares) taking points `from[i]` onto `to[i]` (at least two,
// not all at one place): e.g. a run's plot frame onto its map coordinates.
Registration FitPairs(const std::vector<Eigen::Vector2d>& to,
                      const std::vector<Eigen::Vector2d>& from);

}  // namespace stemmap::merge
