#include "stemmap/merge/compare.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/units.h"
#include "stemmap/merge/csv.h"
#include "stemmap/merge/merge.h"

namespace stemmap::merge {

namespace fs = std::filesystem;

namespace {

// Row r's easting and northing, when both columns exist and both cells hold a number.
std::optional<Eigen::Vector2d> MapXy(const CsvTable& t, size_t r, int ie, int in) {
  if (ie < 0 || in < 0 || ie >= static_cast<int>(t.rows[r].size()) ||
      in >= static_cast<int>(t.rows[r].size()) || t.rows[r][ie].empty() || t.rows[r][in].empty()) {
    return std::nullopt;
  }
  return Eigen::Vector2d(t.Number(r, ie), t.Number(r, in));
}

// A rigid 2-D transform: p -> R(yaw) p + t.
struct Rigid2d {
  double yaw_rad = 0.0;
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  static Rigid2d Of(const Registration& g) { return {g.yaw_deg * kDeg, g.translation_m}; }
  Eigen::Matrix2d R() const {
    const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
    return (Eigen::Matrix2d() << c, -s, s, c).finished();
  }
  Eigen::Vector2d operator*(const Eigen::Vector2d& p) const { return R() * p + t; }
  Rigid2d operator*(const Rigid2d& b) const { return {yaw_rad + b.yaw_rad, R() * b.t + t}; }
  Rigid2d Inverse() const { return {-yaw_rad, -(R().transpose() * t)}; }
};

// The transform taking the points that have map coordinates onto them (nullopt with fewer than
// two such points).
std::optional<Rigid2d> ToMap(const std::vector<Eigen::Vector2d>& xy,
                             const std::vector<std::optional<Eigen::Vector2d>>& map_xy) {
  std::vector<Eigen::Vector2d> to, from;
  for (size_t i = 0; i < xy.size(); ++i) {
    if (map_xy[i]) {
      to.push_back(*map_xy[i]);
      from.push_back(xy[i]);
    }
  }
  if (to.size() < 2) return std::nullopt;
  return Rigid2d::Of(FitPairs(to, from));
}

}  // namespace

std::vector<InventoryTree> ReadInventoryCsv(const fs::path& path) {
  const CsvTable t = ReadCsvTable(path);
  const int ie = t.Column({"easting_m", "easting", "E"}),
            in = t.Column({"northing_m", "northing", "N"});
  int ix = t.Column({"x_m", "x", "X"}), iy = t.Column({"y_m", "y", "Y"});
  if ((ix < 0 || iy < 0) && ie >= 0 && in >= 0) ix = ie, iy = in;  // map coordinates stand for x, y
  const int icm = t.Column({"dbh_cm", "dbh"}), im = t.Column({"dbh_m", "DBH"});
  const int iid = t.Column({"tree_id", "id", "tree", "TreeId"});
  if (ix < 0 || iy < 0 || (icm < 0 && im < 0)) {
    throw InputError(fmt::format(
        "{} needs x and y columns (x_m, y_m, or easting_m, northing_m) and a DBH column (dbh_cm, "
        "or dbh_m in metres)",
        path.string()));
  }
  std::vector<InventoryTree> trees;
  for (size_t r = 0; r < t.rows.size(); ++r) {
    InventoryTree tree;
    tree.id = iid >= 0 && iid < static_cast<int>(t.rows[r].size()) ? t.rows[r][iid]
                                                                   : std::to_string(r + 1);
    tree.stem.xy = {t.Number(r, ix), t.Number(r, iy)};
    tree.stem.dbh_cm = icm >= 0 ? t.Number(r, icm) : 100 * t.Number(r, im);
    tree.map_xy = MapXy(t, r, ie, in);
    trees.push_back(tree);
  }
  if (trees.empty()) throw InputError(fmt::format("{} lists no tree", path.string()));
  return trees;
}

RunTrees ReadRunTrees(const fs::path& run_dir) {
  RunTrees run;
  run.stems = ReadRunStems(run_dir);
  const CsvTable t = ReadCsvTable(run_dir / "trees.csv");
  const int ie = t.Column({"easting_m"}), in = t.Column({"northing_m"});
  for (size_t r = 0; r < t.rows.size(); ++r) run.map_xy.push_back(MapXy(t, r, ie, in));
  return run;
}

void CompareOptions::Check() const {
  registration.Check();
  if (!(min_matched_share > 0 && min_matched_share <= 1) || !(min_dbh_cm >= 0)) {
    throw InputError("compare: the matched share must be in (0, 1] and the DBH floor positive");
  }
  if (!(georeference_max_shift_m > 0) || !(georeference_max_turn_deg > 0)) {
    throw InputError("compare: the georeference's shift and turn bounds must be positive");
  }
}

CompareResult CompareInventories(const CompareOptions& o, const std::vector<InventoryTree>& earlier,
                                 const RunTrees& run_trees) {
  o.Check();
  const std::vector<MapStem>& run = run_trees.stems;
  std::vector<MapStem> earlier_stems;
  std::vector<Eigen::Vector2d> earlier_xy, run_xy;
  std::vector<std::optional<Eigen::Vector2d>> earlier_map;
  for (const InventoryTree& t : earlier) {
    earlier_stems.push_back(t.stem);
    earlier_xy.push_back(t.stem.xy);
    earlier_map.push_back(t.map_xy);
  }
  for (const MapStem& s : run) run_xy.push_back(s.xy);
  CompareResult r;
  const std::optional<Rigid2d> earlier_to_map = ToMap(earlier_xy, earlier_map);
  const std::optional<Rigid2d> run_to_map =
      run_trees.map_xy.size() == run.size() ? ToMap(run_xy, run_trees.map_xy) : std::nullopt;
  std::optional<Rigid2d> implied;  // the earlier frame onto the run's, by the georeferences
  if (earlier_to_map && run_to_map) implied = run_to_map->Inverse() * *earlier_to_map;
  RegistrationGuess guess;
  if (implied) {
    guess.yaw_deg = std::remainder(implied->yaw_rad, 2 * M_PI) / kDeg;
    guess.translation_m = implied->t;
    guess.max_shift_m = o.georeference_max_shift_m;
    guess.max_turn_deg = o.georeference_max_turn_deg;
  }
  r.registration = RegisterMaps(o.registration, run, earlier_stems, implied ? &guess : nullptr);
  if (implied && r.registration.ok) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& p : earlier_xy) c += p;
    c /= static_cast<double>(earlier_xy.size());
    r.georeferenced = true;
    r.georeference_shift_m = (r.registration.Apply(c) - *implied * c).norm();
    r.georeference_turn_deg =
        std::remainder(r.registration.yaw_deg * kDeg - implied->yaw_rad, 2 * M_PI) / kDeg;
  }
  if (!r.registration.ok || r.registration.matched_share < o.min_matched_share) {
    throw InputError(fmt::format(
        "the earlier inventory does not register onto the run{}: {} trees match ({:.0f} % of the "
        "smaller list, {:.0f} % needed): another plot, or too few trees in common",
        implied ? fmt::format(" within {} m and {}° of where the georeferences put it",
                              o.georeference_max_shift_m, o.georeference_max_turn_deg)
                : "",
        r.registration.matches.size(), 100 * r.registration.matched_share,
        100 * o.min_matched_share));
  }
  std::vector<char> run_matched(run.size(), 0), earlier_matched(earlier.size(), 0);
  double growth = 0.0;
  for (const auto& [i, j] : r.registration.matches) {
    run_matched[i] = earlier_matched[j] = 1;
    ComparedTree c;
    c.earlier_id = earlier[j].id;
    c.new_id = i + 1;
    c.xy_m = run[i].xy;
    c.earlier_dbh_cm = earlier[j].stem.dbh_cm;
    c.dbh_cm = run[i].dbh_cm;
    c.match_distance_m = (run[i].xy - r.registration.Apply(earlier[j].stem.xy)).norm();
    growth += c.dbh_cm - c.earlier_dbh_cm;
    r.trees.push_back(c);
    ++r.measured;
  }
  for (size_t i = 0; i < run.size(); ++i) {
    if (run_matched[i] || run[i].dbh_cm < o.min_dbh_cm) continue;
    r.trees.push_back({CompareStatus::kIngrowth, "", static_cast<int>(i) + 1, run[i].xy, 0.0,
                       run[i].dbh_cm, 0.0});
    ++r.ingrowth;
  }
  // An earlier tree beyond the run's farthest stem lies outside what the run lists at all.
  double reach_m = 0.0;
  for (const MapStem& s : run) reach_m = std::max(reach_m, s.xy.norm());
  for (size_t j = 0; j < earlier.size(); ++j) {
    const Eigen::Vector2d at = r.registration.Apply(earlier[j].stem.xy);
    if (earlier_matched[j] || at.norm() > reach_m) continue;
    r.trees.push_back(
        {CompareStatus::kNotFound, earlier[j].id, 0, at, earlier[j].stem.dbh_cm, 0.0, 0.0});
    ++r.not_found;
  }
  r.mean_growth_cm = r.measured > 0 ? growth / r.measured : 0.0;
  return r;
}

namespace {

std::string_view StatusName(CompareStatus s) {
  switch (s) {
    case CompareStatus::kMeasured:
      return "measured";
    case CompareStatus::kIngrowth:
      return "ingrowth";
    case CompareStatus::kNotFound:
      return "not_found";
  }
  return "measured";
}

}  // namespace

CompareResult RunCompare(const CompareOptions& o, const fs::path& earlier_csv,
                         const fs::path& run_dir, const fs::path& out_dir) {
  const CompareResult r =
      CompareInventories(o, ReadInventoryCsv(earlier_csv), ReadRunTrees(run_dir));
  std::string csv =
      "status,earlier_id,tree_id,x_m,y_m,earlier_dbh_cm,dbh_cm,growth_cm,match_distance_m\n";
  for (const ComparedTree& t : r.trees) {
    const bool both = t.status == CompareStatus::kMeasured;
    csv += fmt::format(
        "{},{},{},{:.3f},{:.3f},{},{},{},{}\n", StatusName(t.status), t.earlier_id,
        t.new_id > 0 ? std::to_string(t.new_id) : "", t.xy_m.x(), t.xy_m.y(),
        t.status == CompareStatus::kIngrowth ? "" : fmt::format("{:.1f}", t.earlier_dbh_cm),
        t.status == CompareStatus::kNotFound ? "" : fmt::format("{:.1f}", t.dbh_cm),
        both ? fmt::format("{:.1f}", t.dbh_cm - t.earlier_dbh_cm) : "",
        both ? fmt::format("{:.3f}", t.match_distance_m) : "");
  }
  fs::create_directories(out_dir);
  WriteFileAtomic(out_dir / "compare.csv", csv);
  const Registration& g = r.registration;
  WriteJsonAtomic(out_dir / "compare.json",
                  {{"earlier", fs::absolute(earlier_csv).string()},
                   {"run", fs::absolute(run_dir).string()},
                   {"yaw_deg", g.yaw_deg},
                   {"translation_m", {g.translation_m.x(), g.translation_m.y()}},
                   {"rms_m", g.rms_m},
                   {"measured", r.measured},
                   {"ingrowth", r.ingrowth},
                   {"not_found", r.not_found},
                   {"mean_growth_cm", r.mean_growth_cm},
                   {"georeferenced", r.georeferenced},
                   {"georeference_shift_m", r.georeference_shift_m},
                   {"georeference_turn_deg", r.georeference_turn_deg}});
  return r;
}

}  // namespace stemmap::merge
