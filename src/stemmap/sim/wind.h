#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "stemmap/sim/render.h"
#include "stemmap/sim/scene.h"

namespace stemmap::sim {

// Wind in the understory: shrubs, saplings (with their leaf clumps) and the crown layer sway,
// each about its rest pose with its own periods (1-4 s) and phases drawn from the seed, mostly
// along one prevailing direction. Stems of trees (not saplings) stand still, so the truth of the
// measured trees holds in any wind.
class Wind {
 public:
  // `strength` in [0, 1]: 0 still air; 1 a fresh breeze, where shrubs sway by about 5 cm, the
  // tops of 2-5 m saplings by 4-10 cm (a tilt of 0.02 rad about the base) and the crowns by 30 cm.
  Wind(const Scene& scene, double strength, uint64_t seed);

  // The scene's sway at time t_s (stand frame); nothing moves at strength 0.
  SceneSway At(double t_s) const;

  static constexpr double kShrubSwayM = 0.05;      // at strength 1
  static constexpr double kSaplingTiltRad = 0.02;  // at strength 1
  static constexpr double kCrownSwayM = 0.3;       // at strength 1

 private:
  // One object's oscillation: along the wind and, weaker, across it.
  struct Oscillator {
    double amplitude = 0.0;  // m, or rad for a tilt
    double omega_along = 0.0, phase_along = 0.0;
    double omega_across = 0.0, phase_across = 0.0;
    // Displacement in the horizontal plane, in units of the amplitude.
    Eigen::Vector2d At(double t_s, const Eigen::Vector2d& along) const;
  };

  const Scene& scene_;
  double strength_ = 0.0;
  Eigen::Vector2d along_ = Eigen::Vector2d::UnitX();  // prevailing direction
  std::vector<Oscillator> shrubs_, trees_;            // per shrub, per tree (saplings only move)
  Oscillator crowns_;
};

}  // namespace stemmap::sim
