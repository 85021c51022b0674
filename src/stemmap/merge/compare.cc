#include "stemmap/merge/compare.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/merge/csv.h"
#include "stemmap/merge/merge.h"

namespace stemmap::merge {

namespace fs = std::filesystem;

std::vector<InventoryTree> ReadInventoryCsv(const fs::path& path) {
  const CsvTable t = ReadCsvTable(path);
  const int ix = t.Column({"x_m", "x", "X"}), iy = t.Column({"y_m", "y", "Y"});
  const int icm = t.Column({"dbh_cm", "dbh"}), im = t.Column({"dbh_m", "DBH"});
  const int iid = t.Column({"tree_id", "id", "tree", "TreeId"});
  if (ix < 0 || iy < 0 || (icm < 0 && im < 0)) {
    throw InputError(fmt::format(
        "{} needs x and y columns (x_m, y_m) and a DBH column (dbh_cm, or dbh_m in metres)",
        path.string()));
  }
  std::vector<InventoryTree> trees;
  for (size_t r = 0; r < t.rows.size(); ++r) {
    InventoryTree tree;
    tree.id = iid >= 0 && iid < static_cast<int>(t.rows[r].size()) ? t.rows[r][iid]
                                                                   : std::to_string(r + 1);
    tree.stem.xy = {t.Number(r, ix), t.Number(r, iy)};
    tree.stem.dbh_cm = icm >= 0 ? t.Number(r, icm) : 100 * t.Number(r, im);
    trees.push_back(tree);
  }
  if (trees.empty()) throw InputError(fmt::format("{} lists no tree", path.string()));
  return trees;
}

void CompareOptions::Check() const {
  registration.Check();
  if (!(min_matched_share > 0 && min_matched_share <= 1) || !(min_dbh_cm >= 0)) {
    throw InputError("compare: the matched share must be in (0, 1] and the DBH floor positive");
  }
}

CompareResult CompareInventories(const CompareOptions& o, const std::vector<InventoryTree>& earlier,
                                 const std::vector<MapStem>& run) {
  o.Check();
  std::vector<MapStem> earlier_stems;
  for (const InventoryTree& t : earlier) earlier_stems.push_back(t.stem);
  CompareResult r;
  r.registration = RegisterMaps(o.registration, run, earlier_stems);
  if (!r.registration.ok || r.registration.matched_share < o.min_matched_share) {
    throw InputError(fmt::format(
        "the earlier inventory does not register onto the run: {} trees match ({:.0f} % of the "
        "smaller list, {:.0f} % needed): another plot, or too few trees in common",
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
      CompareInventories(o, ReadInventoryCsv(earlier_csv), ReadRunStems(run_dir));
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
                   {"mean_growth_cm", r.mean_growth_cm}});
  return r;
}

}  // namespace stemmap::merge
