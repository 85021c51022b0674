#include "stemmap/sim/wind.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "stemmap/core/rng.h"

namespace stemmap::sim {

Eigen::Vector2d Wind::Oscillator::At(double t_s, const Eigen::Vector2d& along) const {
  const Eigen::Vector2d across(-along.y(), along.x());
  return amplitude * (std::sin(omega_along * t_s + phase_along) * along +
                      0.4 * std::sin(omega_across * t_s + phase_across) * across);
}

Wind::Wind(const Scene& scene, double strength, uint64_t seed)
    : scene_(scene), strength_(strength) {
  Rng rng(HashCombine(seed, 0x57494E44));
  const double heading = rng.Uniform(0.0, 2.0 * std::numbers::pi);
  along_ = {std::cos(heading), std::sin(heading)};
  // Small plants swing fast, tall ones slowly: periods drawn within each kind's range.
  const auto draw = [&](double amplitude, double min_period_s, double max_period_s) {
    Oscillator o;
    o.amplitude = amplitude;
    o.omega_along = 2.0 * std::numbers::pi / rng.Uniform(min_period_s, max_period_s);
    o.phase_along = rng.Uniform(0.0, 2.0 * std::numbers::pi);
    o.omega_across = 2.0 * std::numbers::pi / rng.Uniform(min_period_s, max_period_s);
    o.phase_across = rng.Uniform(0.0, 2.0 * std::numbers::pi);
    return o;
  };
  for (size_t k = 0; k < scene.shrubs.size(); ++k) {
    shrubs_.push_back(draw(strength * kShrubSwayM, 1.0, 2.5));
  }
  for (const SceneTree& t : scene.trees) {
    trees_.push_back(t.sapling ? draw(strength * kSaplingTiltRad, 1.5, 4.0) : Oscillator{});
  }
  crowns_ = draw(strength * kCrownSwayM, 2.5, 4.0);
}

SceneSway Wind::At(double t_s) const {
  SceneSway sway;
  if (!(strength_ > 0.0)) return sway;
  sway.tree_tilt.resize(trees_.size(), Eigen::Quaterniond::Identity());
  for (size_t i = 0; i < trees_.size(); ++i) {
    if (trees_[i].amplitude == 0.0) continue;
    // A tilt toward the horizontal displacement: a point at height z moves by about tilt × z.
    const Eigen::Vector2d lean = trees_[i].At(t_s, along_);
    const double angle = lean.norm();
    if (angle == 0.0) continue;
    const Eigen::Vector3d axis =
        Eigen::Vector3d::UnitZ().cross(Eigen::Vector3d(lean.x(), lean.y(), 0.0) / angle);
    sway.tree_tilt[i] = Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis));
  }
  sway.shrub_offset_m.resize(shrubs_.size());
  for (size_t k = 0; k < shrubs_.size(); ++k) {
    const Shrub& sh = scene_.shrubs[k];
    if (sh.tree >= 0) {
      // A sapling's leaf clump moves with its stem.
      const Eigen::Vector3d& base = scene_.trees[sh.tree].stem.params().base_world;
      sway.shrub_offset_m[k] = sway.tree_tilt[sh.tree] * (sh.centre - base) + base - sh.centre;
      continue;
    }
    const Eigen::Vector2d d = shrubs_[k].At(t_s, along_);
    sway.shrub_offset_m[k] = {d.x(), d.y(), 0.0};
  }
  const Eigen::Vector2d c = crowns_.At(t_s, along_);
  sway.crown_offset_m = {c.x(), c.y(), 0.0};
  return sway;
}

}  // namespace stemmap::sim
