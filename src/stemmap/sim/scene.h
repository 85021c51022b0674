#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "stemmap/sim/ground.h"
#include "stemmap/sim/stem.h"

namespace stemmap::sim {

enum class StandKind { kManaged, kNatural };
StandKind ParseStandKind(const std::string& s);
std::string ToString(StandKind k);

// One stem of a field stem map (positions in metres from the plot centre, DBH in cm).
struct LayoutStem {
  double x_m = 0.0;
  double y_m = 0.0;
  double dbh_cm = 0.0;
};

// Reads a CSV with (case-insensitive) columns x, y, dbh; when a plot column (`id` or `plot`) is
// present, keeps the rows of `plot_id` (or the first plot when `plot_id` is empty).
std::vector<LayoutStem> ReadLayoutCsv(const std::filesystem::path& path,
                                      const std::string& plot_id = "");

struct SceneOptions {
  StandKind kind = StandKind::kManaged;
  uint64_t seed = 1;
  double scene_radius_m = 40.0;    // trees are placed out to here; beyond is a distant forest wall
  double keep_clear_m = 1.7;       // no stem this close to the axis (the arm sweeps 1 m)
  std::vector<LayoutStem> layout;  // when not empty, the plot's stems come from it
  void Check() const;
};

struct Shrub {
  Eigen::Vector3d centre;   // world
  Eigen::Vector3d radii_m;  // ellipsoid semi-axes
  double density = 0.5;     // share of the volume that is leaves
  uint64_t seed = 0;
  int tree = -1;  // the sapling it is a leaf clump of (it sways with it), or -1 for a shrub
};

struct SceneTree {
  int id = 0;
  Stem stem;
  bool sapling = false;
  explicit SceneTree(const StemParams& p) : stem(p) {}
};

struct Lighting {
  Eigen::Vector3d sun_dir_world;  // unit, toward the sun
  Eigen::Vector3f sun_rgb;        // irradiance on a surface facing the sun
  Eigen::Vector3f sky_rgb;        // ambient irradiance
  double canopy_base_m = 9.0;     // foliage layer (trunks run up into it)
  double canopy_top_m = 22.0;
  double canopy_cover = 0.7;  // share of the sky hidden by crowns
  uint64_t seed = 0;
};

struct Scene {
  StandKind kind = StandKind::kManaged;
  Ground ground;
  std::vector<SceneTree> trees;  // plot trees and saplings
  std::vector<Shrub> shrubs;
  Lighting light;
  double scene_radius_m = 40.0;
};

Scene GenerateScene(const SceneOptions& options);

// Height above ground used for DBH (m), and where the truth measures it on a stem.
inline constexpr double kBreastHeightM = 1.37;

}  // namespace stemmap::sim
