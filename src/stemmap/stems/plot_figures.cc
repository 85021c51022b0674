#include "stemmap/stems/plot_figures.h"

#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/core/rng.h"

namespace stemmap::stems {

namespace {

constexpr double kRadialStepM = 0.1, kAzimuthStepDeg = 0.5;

// A listed stem as one keyframe sees it: its bearing, half its angular width, its distance.
struct SeenStem {
  double bearing = 0.0, half_width = 0.0, distance_m = 0.0;
};

double AngleApart(double a, double b) { return std::abs(std::remainder(a - b, 2 * M_PI)); }

}  // namespace

Visibility HiddenBehindStems(const std::vector<Stem>& trees,
                             const std::vector<StampedPose>& keyframes, const PinholeCamera& camera,
                             double plot_radius_m) {
  Visibility v;
  v.plot_area_m2 = M_PI * plot_radius_m * plot_radius_m;
  const double half_fov = std::atan2(0.5 * camera.width, camera.fx);
  struct View {
    Eigen::Vector2d centre;
    double heading = 0.0;
    std::vector<SeenStem> stems;
  };
  std::vector<View> views;
  for (const StampedPose& k : keyframes) {
    View view;
    view.centre = k.world_from_cam.translation.head<2>();
    const Eigen::Vector3d forward = k.world_from_cam.rotation * Eigen::Vector3d::UnitZ();
    view.heading = std::atan2(forward.y(), forward.x());
    for (const Stem& s : trees) {
      const Eigen::Vector2d d = s.centre_xy - view.centre;
      const double r = 0.5 * s.dbh_m, dist = d.norm();
      if (dist <= r) continue;
      view.stems.push_back({std::atan2(d.y(), d.x()), std::asin(r / dist), dist});
    }
    views.push_back(std::move(view));
  }
  const int n_az = static_cast<int>(std::lround(360.0 / kAzimuthStepDeg));
  std::vector<HiddenSector> by_tree(trees.size());
  std::vector<double> az_min(trees.size(), 1e9), az_max(trees.size(), -1e9);
  std::vector<double> from_m(trees.size(), 1e9);
  std::vector<double> bearing_from_centre;  // of each listed stem, once
  for (const Stem& s : trees)
    bearing_from_centre.push_back(std::atan2(s.centre_xy.y(), s.centre_xy.x()));
  for (int a = 0; a < n_az; ++a) {
    const double az = (a + 0.5) * kAzimuthStepDeg * M_PI / 180.0;
    for (double r = 0.5 * kRadialStepM; r < plot_radius_m; r += kRadialStepM) {
      const Eigen::Vector2d p(r * std::cos(az), r * std::sin(az));
      bool seen = false, in_view = false;
      for (const View& view : views) {
        const Eigen::Vector2d d = p - view.centre;
        const double bearing = std::atan2(d.y(), d.x()), dist = d.norm();
        if (AngleApart(bearing, view.heading) > half_fov) continue;
        in_view = true;
        const bool blocked = std::ranges::any_of(view.stems, [&](const SeenStem& s) {
          return s.distance_m < dist && AngleApart(bearing, s.bearing) < s.half_width;
        });
        if (!blocked) {
          seen = true;
          break;
        }
      }
      // Ground no keyframe looked at (a turn cut short) is not ground behind a stem.
      if (seen || !in_view) continue;
      const double cell_m2 = r * kRadialStepM * kAzimuthStepDeg * M_PI / 180.0;
      v.hidden_area_m2 += cell_m2;
      // The stem behind which it lies: the nearest in bearing of those nearer the centre.
      int best = -1;
      double best_apart = 1e9;
      for (size_t i = 0; i < trees.size(); ++i) {
        if (trees[i].centre_xy.norm() >= r) continue;
        const double apart = AngleApart(az, bearing_from_centre[i]);
        if (apart < best_apart) best_apart = apart, best = static_cast<int>(i);
      }
      if (best < 0) continue;
      HiddenSector& h = by_tree[best];
      h.area_m2 += cell_m2;
      from_m[best] = std::min(from_m[best], r);
      h.to_m = std::max(h.to_m, r);
      const double off = std::remainder(az - bearing_from_centre[best], 2 * M_PI);
      az_min[best] = std::min(az_min[best], off);
      az_max[best] = std::max(az_max[best], off);
    }
  }
  for (size_t i = 0; i < trees.size(); ++i) {
    HiddenSector& h = by_tree[i];
    if (h.area_m2 <= 0) continue;
    const Eigen::Vector2d& c = trees[i].centre_xy;
    h.tree = static_cast<int>(i);
    h.from_m = from_m[i];
    h.azimuth_deg = std::atan2(c.y(), c.x()) * 180.0 / M_PI;
    if (h.azimuth_deg < 0) h.azimuth_deg += 360.0;
    h.half_width_deg = 0.5 * (az_max[i] - az_min[i] + kAzimuthStepDeg * M_PI / 180.0) * 180 / M_PI;
    v.sectors.push_back(h);
  }
  return v;
}

void PlotFigureOptions::Check() const {
  if (!(plot_radius_m > 0)) throw InputError("--plot-radius must be positive");
  if (min_dbh_cm < 0) throw InputError("--min-dbh must not be negative");
  if (interval_draws < 100) throw InputError("the plot intervals need at least 100 draws");
  if (!(class_width_cm > 0)) throw InputError("the stand table's class width must be positive");
  if (!(dominant_stems_per_ha > 0)) {
    throw InputError("the dominant diameter needs a positive number of stems a hectare");
  }
  if (!(listed_share_in_view > 0 && listed_share_in_view <= 1)) {
    throw InputError("the share of the stems in view that are listed must lie in (0, 1]");
  }
  occlusion.Check();
}

namespace {

// Quadratic mean of the `count` largest DBHs (cm), the last one weighted by count's fraction;
// all of them when there are fewer.
double DominantDiameter(std::vector<double> dbh_cm, double count) {
  if (dbh_cm.empty()) return 0.0;
  std::ranges::sort(dbh_cm, std::greater<>());
  double sum_w = 0.0, sum_d2 = 0.0;
  for (size_t i = 0; i < dbh_cm.size() && sum_w < count; ++i) {
    const double w = std::min(1.0, count - sum_w);
    sum_w += w;
    sum_d2 += w * dbh_cm[i] * dbh_cm[i];
  }
  return std::sqrt(sum_d2 / sum_w);
}

std::vector<DbhClass> StandTable(const std::vector<double>& dbh_cm, double width_cm,
                                 double area_ha) {
  std::vector<DbhClass> table;
  if (dbh_cm.empty()) return table;
  const auto [lo, hi] = std::ranges::minmax(dbh_cm);
  const int first = static_cast<int>(std::floor(lo / width_cm));
  const int last = static_cast<int>(std::floor(hi / width_cm));
  for (int k = first; k <= last; ++k) table.push_back({k * width_cm, (k + 1) * width_cm});
  for (double d : dbh_cm) {
    DbhClass& c = table[static_cast<int>(std::floor(d / width_cm)) - first];
    ++c.stems;
    c.stems_per_ha += 1.0 / area_ha;
    c.basal_area_m2_per_ha += M_PI * std::pow(d / 200.0, 2) / area_ha;
  }
  return table;
}

// Stems/ha, basal area/ha, QMD and dominant diameter of DBHs (cm) on `area_ha`.
struct Figures {
  double per_ha = 0.0, basal_per_ha = 0.0, qmd_cm = 0.0, dominant_cm = 0.0;
};
Figures FiguresOf(const std::vector<double>& dbh_cm, double area_ha, double dominant_per_ha) {
  Figures f;
  f.dominant_cm = DominantDiameter(dbh_cm, dominant_per_ha * area_ha);
  double sum_ba = 0.0, sum_d2 = 0.0;
  for (double d : dbh_cm) {
    sum_ba += M_PI * std::pow(d / 200.0, 2);
    sum_d2 += d * d;
  }
  f.per_ha = dbh_cm.size() / area_ha;
  f.basal_per_ha = sum_ba / area_ha;
  f.qmd_cm = dbh_cm.empty() ? 0.0 : std::sqrt(sum_d2 / dbh_cm.size());
  return f;
}

int Poisson(double mean, Rng* rng) {
  // Knuth's product of uniforms; the hidden stems of one plot are few.
  const double limit = std::exp(-mean);
  int k = 0;
  for (double p = rng->Uniform(); p > limit; p *= rng->Uniform()) ++k;
  return k;
}

}  // namespace

PlotFigures ComputePlotFigures(const PlotFigureOptions& o, const std::vector<Stem>& trees,
                               const Visibility& visibility) {
  o.Check();
  const double area_ha = M_PI * o.plot_radius_m * o.plot_radius_m / 1e4;
  std::vector<const Stem*> in_plot;
  std::vector<double> dbh_cm;
  for (const Stem& s : trees) {
    if (s.centre_xy.norm() > o.plot_radius_m || 100 * s.dbh_m < o.min_dbh_cm) continue;
    in_plot.push_back(&s);
    dbh_cm.push_back(100 * s.dbh_m);
  }
  PlotFigures f;
  f.stems = static_cast<int>(in_plot.size());
  const Figures listed = FiguresOf(dbh_cm, area_ha, o.dominant_stems_per_ha);
  f.stems_per_ha = listed.per_ha;
  f.basal_area_m2_per_ha = listed.basal_per_ha;
  f.qmd_cm = listed.qmd_cm;
  // The hidden ground holds stems at the density of the ground seen.
  const double seen_m2 = std::max(1.0, visibility.plot_area_m2 - visibility.hidden_area_m2);
  f.expected_hidden_stems = f.stems * visibility.hidden_area_m2 / seen_m2;
  const double expected_missed = f.stems * (1.0 - o.listed_share_in_view) / o.listed_share_in_view;
  Rng rng(o.seed);
  std::vector<double> per_ha, basal, qmd, dominant;
  std::vector<double> draw;
  for (int k = 0; k < o.interval_draws; ++k) {
    draw.clear();
    for (const Stem* s : in_plot) {
      if (!rng.Bernoulli(s->confidence)) continue;
      const double d = rng.Normal(100 * s->dbh_m, 100 * s->dbh_sd_m);
      if (d >= o.min_dbh_cm) draw.push_back(d);
    }
    const int hidden =
        dbh_cm.empty() ? 0 : Poisson(f.expected_hidden_stems + expected_missed, &rng);
    for (int h = 0; h < hidden; ++h) {
      draw.push_back(dbh_cm[rng.UniformInt(0, static_cast<int>(dbh_cm.size()) - 1)]);
    }
    const Figures g = FiguresOf(draw, area_ha, o.dominant_stems_per_ha);
    per_ha.push_back(g.per_ha);
    basal.push_back(g.basal_per_ha);
    qmd.push_back(g.qmd_cm);
    dominant.push_back(g.dominant_cm);
  }
  f.stems_per_ha_95 = Percentiles95(per_ha);
  f.basal_area_m2_per_ha_95 = Percentiles95(basal);
  f.qmd_cm_95 = Percentiles95(qmd);
  f.dominant_diameter_cm = listed.dominant_cm;
  f.dominant_diameter_cm_95 = Percentiles95(dominant);
  f.plot_area_m2 = area_ha * 1e4;
  f.stand_table = StandTable(dbh_cm, o.class_width_cm, area_ha);
  std::vector<double> distances_m;
  for (const Stem* s : in_plot) distances_m.push_back(s->centre_xy.norm());
  f.occlusion = CorrectForOcclusion(o.occlusion, distances_m, dbh_cm, o.plot_radius_m);
  for (const Stem& s : trees) {
    if (100 * s.dbh_m < o.min_dbh_cm) continue;
    const double d = s.centre_xy.norm();
    if (std::abs(d - o.plot_radius_m) > s.dbh_m) continue;
    ++f.borderline_stems;
    if (d <= o.plot_radius_m) ++f.borderline_counted;
  }
  return f;
}

}  // namespace stemmap::stems
