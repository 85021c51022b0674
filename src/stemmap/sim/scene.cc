#include "stemmap/sim/scene.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <sstream>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/rng.h"
#include "stemmap/core/units.h"

namespace stemmap::sim {

namespace {

struct Placed {
  Eigen::Vector2d xy;  // stem position at breast height
  double dbh_cm;
  bool sapling;
};

bool FarEnough(const std::vector<Placed>& placed, const Eigen::Vector2d& xy, double dbh_cm) {
  for (const Placed& p : placed) {
    const double min_gap = (p.dbh_cm + dbh_cm) / 200.0 * 1.5 + 0.35;
    if ((p.xy - xy).squaredNorm() < min_gap * min_gap) return false;
  }
  return true;
}

double DrawDbhCm(StandKind kind, double managed_mean_cm, Rng& rng) {
  if (kind == StandKind::kManaged) return std::clamp(rng.Normal(managed_mean_cm, 5.5), 10.0, 60.0);
  // Natural stands: many small stems, a few big ones.
  return std::clamp(10.0 - 11.0 * std::log(1.0 - rng.Uniform() * 0.985), 10.0, 60.0);
}

void PlaceManaged(const SceneOptions& o, Rng& rng, double r_min, std::vector<Placed>* placed) {
  const double sx = rng.Uniform(3.5, 5.0), sy = rng.Uniform(3.5, 5.0);
  const double rot = rng.Uniform(0, std::numbers::pi);
  const Eigen::Vector2d offset(rng.Uniform(0, sx), rng.Uniform(0, sy));
  const double mean_cm = rng.Uniform(24.0, 38.0);
  const Eigen::Rotation2Dd grid_to_world(rot);
  const int n = static_cast<int>(o.scene_radius_m / std::min(sx, sy)) + 2;
  for (int i = -n; i <= n; ++i) {
    for (int j = -n; j <= n; ++j) {
      Eigen::Vector2d xy = grid_to_world * (Eigen::Vector2d(i * sx, j * sy) + offset);
      xy += Eigen::Vector2d(rng.Normal(0, 0.25), rng.Normal(0, 0.25));
      const double dbh = DrawDbhCm(StandKind::kManaged, mean_cm, rng);
      if (rng.Bernoulli(0.12)) continue;  // gaps: dead or thinned trees
      const double r = xy.norm();
      if (r < std::max(r_min, o.keep_clear_m) || r > o.scene_radius_m) continue;
      if (FarEnough(*placed, xy, dbh)) placed->push_back({xy, dbh, false});
    }
  }
}

void PlaceNatural(const SceneOptions& o, Rng& rng, double r_min, std::vector<Placed>* placed) {
  // Thomas cluster process plus scattered singles, with a hard-core distance.
  const double area = std::numbers::pi * o.scene_radius_m * o.scene_radius_m;
  const int clusters = static_cast<int>(area / rng.Uniform(120.0, 200.0));
  auto try_place = [&](Eigen::Vector2d xy) {
    const double r = xy.norm();
    if (r < std::max(r_min, o.keep_clear_m) || r > o.scene_radius_m) return;
    const double dbh = DrawDbhCm(StandKind::kNatural, 0, rng);
    if (FarEnough(*placed, xy, dbh)) placed->push_back({xy, dbh, false});
  };
  for (int c = 0; c < clusters; ++c) {
    const double r = o.scene_radius_m * std::sqrt(rng.Uniform());
    const double a = rng.Uniform(0, 2 * std::numbers::pi);
    const Eigen::Vector2d centre(r * std::cos(a), r * std::sin(a));
    const int children = rng.UniformInt(1, 6);
    for (int k = 0; k < children; ++k) {
      try_place(centre + Eigen::Vector2d(rng.Normal(0, 2.2), rng.Normal(0, 2.2)));
    }
  }
  const int singles = static_cast<int>(area / 90.0);
  for (int k = 0; k < singles; ++k) {
    const double r = o.scene_radius_m * std::sqrt(rng.Uniform());
    const double a = rng.Uniform(0, 2 * std::numbers::pi);
    try_place({r * std::cos(a), r * std::sin(a)});
  }
}

StemParams MakeStem(const Placed& t, StandKind kind, const Ground& ground, Rng& rng) {
  StemParams p;
  p.seed = rng.NextU64();
  const double r_bh = t.dbh_cm / 200.0;
  p.radius_bh_m = r_bh;
  p.lean_rad = rng.Uniform(0.0, t.sapling ? 6.0 : 4.0) * kDeg;
  p.lean_azimuth_rad = rng.Uniform(0, 2 * std::numbers::pi);
  p.taper_m_per_m = rng.Uniform(0.008, 0.015) / 2.0;
  p.axis_ratio = t.sapling ? 1.0 : rng.Uniform(0.88, 1.0);
  p.ellipse_azimuth_rad = rng.Uniform(0, std::numbers::pi);
  p.flare = t.sapling ? 0.05 : rng.Uniform(0.12, kind == StandKind::kNatural ? 0.5 : 0.35);
  p.flare_height_m = rng.Uniform(0.22, 0.4);
  p.furrow_depth_m =
      t.sapling ? 0.0005 : (0.0015 + 0.007 * t.dbh_cm / 60.0) * rng.Uniform(0.7, 1.3);
  p.furrow_spacing_m = t.sapling ? 0.01 : rng.Uniform(0.02, 0.05);
  p.height_m = t.sapling ? rng.Uniform(2.0, 5.0) : rng.Uniform(16.0, 28.0);
  // Bark palettes: grey-brown pine, grey beech/oak-like, dark spruce-like.
  static const Eigen::Vector3f kPalettes[] = {
      {0.30f, 0.24f, 0.20f}, {0.32f, 0.31f, 0.29f}, {0.22f, 0.19f, 0.17f}, {0.36f, 0.29f, 0.22f}};
  const int palette = kind == StandKind::kManaged ? 0 : rng.UniformInt(0, 3);
  p.bark_rgb = kPalettes[palette];
  for (int c = 0; c < 3; ++c) p.bark_rgb[c] *= static_cast<float>(rng.Uniform(0.85, 1.15));
  p.lichen = rng.Uniform(0.0, 0.45);
  p.moss = kind == StandKind::kNatural ? rng.Uniform(0.0, 0.6) : rng.Uniform(0.0, 0.3);

  // Place the axis so that its breast-height point lands on the requested position. Breast
  // height is measured from the ground on the uphill side of the stem.
  const Eigen::Vector2d axis_xy =
      std::sin(p.lean_rad) *
      Eigen::Vector2d(std::cos(p.lean_azimuth_rad), std::sin(p.lean_azimuth_rad));
  Eigen::Vector2d base_xy = t.xy;
  for (int it = 0; it < 4; ++it) {
    const double base_z = ground.Height(base_xy.x(), base_xy.y());
    Eigen::Vector2d g = ground.Gradient(base_xy.x(), base_xy.y());
    const Eigen::Vector2d uphill =
        g.norm() > 1e-9 ? Eigen::Vector2d(g.normalized()) : Eigen::Vector2d(1, 0);
    const Eigen::Vector2d up_pt = base_xy + r_bh * uphill;
    const double z_up = ground.Height(up_pt.x(), up_pt.y());
    p.s_bh_m = (std::max(z_up, base_z) + kBreastHeightM - base_z) / std::cos(p.lean_rad);
    base_xy = t.xy - p.s_bh_m * axis_xy;
    p.base_world = Eigen::Vector3d(base_xy.x(), base_xy.y(), base_z);
  }
  p.base_world.z() = ground.Height(base_xy.x(), base_xy.y());
  return p;
}

}  // namespace

StandKind ParseStandKind(const std::string& s) {
  if (s == "managed") return StandKind::kManaged;
  if (s == "natural") return StandKind::kNatural;
  throw InputError(fmt::format("unknown stand kind '{}': use managed or natural", s));
}

std::string ToString(StandKind k) { return k == StandKind::kManaged ? "managed" : "natural"; }

void SceneOptions::Check() const {
  if (!(scene_radius_m >= 25.0 && scene_radius_m <= 80.0)) {
    throw InputError(fmt::format("scene radius {} m out of [25, 80]", scene_radius_m));
  }
  for (const LayoutStem& s : layout) {
    if (!(s.dbh_cm > 0.5 && s.dbh_cm < 300) || !std::isfinite(s.x_m) || !std::isfinite(s.y_m)) {
      throw InputError(fmt::format("layout stem at ({}, {}) with DBH {} cm is not plausible", s.x_m,
                                   s.y_m, s.dbh_cm));
    }
  }
}

Scene GenerateScene(const SceneOptions& o) {
  o.Check();
  Rng rng(o.seed);
  Scene scene;
  scene.kind = o.kind;
  scene.scene_radius_m = o.scene_radius_m;
  const bool natural = o.kind == StandKind::kNatural;
  scene.ground = Ground(natural ? rng.Uniform(2.0, 8.0) : rng.Uniform(0.0, 3.0),
                        rng.Uniform(0, 2 * std::numbers::pi),
                        natural ? rng.Uniform(0.08, 0.18) : rng.Uniform(0.03, 0.07),
                        natural ? 3.5 : 5.0, rng.NextU64(), o.scene_radius_m + 15.0);

  std::vector<Placed> placed;
  double r_fill = 0.0;
  if (!o.layout.empty()) {
    for (const LayoutStem& s : o.layout) {
      const Eigen::Vector2d xy(s.x_m, s.y_m);
      if (xy.norm() < o.keep_clear_m) {
        spdlog::warn("layout stem at ({:.2f}, {:.2f}) is inside the arm's sweep; dropped", s.x_m,
                     s.y_m);
        continue;
      }
      placed.push_back({xy, s.dbh_cm, false});
      r_fill = std::max(r_fill, xy.norm() + 1.0);
    }
  }
  Rng place_rng = rng.Fork(1);
  if (o.kind == StandKind::kManaged && o.layout.empty()) {
    PlaceManaged(o, place_rng, r_fill, &placed);
  } else {
    PlaceNatural(o, place_rng, r_fill, &placed);
  }
  std::sort(placed.begin(), placed.end(),
            [](const Placed& a, const Placed& b) { return a.xy.norm() < b.xy.norm(); });

  if (natural) {
    // Saplings: thin stems (< 7 cm) that are not plot trees but hide parts of them.
    Rng srng = rng.Fork(2);
    const int n = srng.UniformInt(25, 55);
    for (int k = 0; k < n; ++k) {
      const double r = std::sqrt(srng.Uniform(2.2 * 2.2, 22.0 * 22.0));
      const double a = srng.Uniform(0, 2 * std::numbers::pi);
      const Eigen::Vector2d xy(r * std::cos(a), r * std::sin(a));
      const double dbh = srng.Uniform(1.5, 6.5);
      if (FarEnough(placed, xy, dbh)) placed.push_back({xy, dbh, true});
    }
  }

  Rng stem_rng = rng.Fork(3);
  int next_id = 1;
  for (const Placed& t : placed) {
    SceneTree tree(MakeStem(t, o.kind, scene.ground, stem_rng));
    tree.sapling = t.sapling;
    tree.id = next_id++;
    if (t.sapling) {
      // A few sparse leaf clumps along the sapling's upper stem.
      const double h = tree.stem.params().height_m;
      for (int c = 0; c < 3; ++c) {
        const double s_clump = h * stem_rng.Uniform(0.55, 0.95);
        const Eigen::Vector3d centre =
            tree.stem.AxisPoint(s_clump) +
            Eigen::Vector3d(stem_rng.Normal(0, 0.15), stem_rng.Normal(0, 0.15), 0);
        const double rr = stem_rng.Uniform(0.25, 0.55);
        scene.shrubs.push_back({centre,
                                {rr, rr * stem_rng.Uniform(0.7, 1.2), rr * 0.7},
                                stem_rng.Uniform(0.25, 0.45),
                                stem_rng.NextU64()});
        scene.shrubs.back().tree = static_cast<int>(scene.trees.size());
      }
    }
    scene.trees.push_back(std::move(tree));
  }

  // Understory shrubs in natural stands.
  Rng shrub_rng = rng.Fork(4);
  const int n_shrubs = natural ? shrub_rng.UniformInt(35, 70) : shrub_rng.UniformInt(0, 4);
  for (int k = 0; k < n_shrubs; ++k) {
    const double r = std::sqrt(shrub_rng.Uniform(2.6 * 2.6, 25.0 * 25.0));
    const double a = shrub_rng.Uniform(0, 2 * std::numbers::pi);
    const Eigen::Vector2d xy(r * std::cos(a), r * std::sin(a));
    const double rx = shrub_rng.Uniform(0.3, 1.0), ry = shrub_rng.Uniform(0.3, 1.0);
    const double rz = shrub_rng.Uniform(0.3, 0.8);
    const double z = scene.ground.Height(xy.x(), xy.y()) + 0.6 * rz;
    scene.shrubs.push_back(
        {{xy.x(), xy.y(), z}, {rx, ry, rz}, shrub_rng.Uniform(0.3, 0.6), shrub_rng.NextU64()});
  }

  Lighting& L = scene.light;
  const double elev = rng.Uniform(25.0, 55.0) * kDeg, az = rng.Uniform(0, 2 * std::numbers::pi);
  L.sun_dir_world = {std::cos(elev) * std::cos(az), std::cos(elev) * std::sin(az), std::sin(elev)};
  L.sun_rgb = Eigen::Vector3f(1.0f, 0.93f, 0.80f) * static_cast<float>(rng.Uniform(2.5, 4.0));
  L.sky_rgb = Eigen::Vector3f(0.50f, 0.58f, 0.70f) * static_cast<float>(rng.Uniform(0.7, 1.0));
  L.canopy_base_m = rng.Uniform(7.0, 11.0);
  L.canopy_top_m = L.canopy_base_m + rng.Uniform(8.0, 14.0);
  L.canopy_cover = natural ? rng.Uniform(0.65, 0.85) : rng.Uniform(0.55, 0.75);
  L.seed = rng.NextU64();
  return scene;
}

}  // namespace stemmap::sim
