#include "stemmap/merge/merge.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/merge/csv.h"

namespace stemmap::merge {

namespace fs = std::filesystem;

void MergeOptions::Check() const {
  registration.Check();
  if (!(min_matched_share > 0 && min_matched_share <= 1) || !(max_rms_m > 0)) {
    throw InputError("merge: the matched share must be in (0, 1] and the residual positive");
  }
}

namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::ranges::sort(v);
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Cluster {
  std::vector<Eigen::Vector2d> xy;
  std::vector<double> dbh_cm;
  std::vector<int> runs;
  Eigen::Vector2d MeanXy() const {
    Eigen::Vector2d m = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& p : xy) m += p;
    return m / xy.size();
  }
  double MeanDbh() const {
    double s = 0.0;
    for (double d : dbh_cm) s += d;
    return s / dbh_cm.size();
  }
};

MergedTree ToTree(const Cluster& c) {
  MergedTree t;
  t.xy_m = c.MeanXy();
  t.dbh_cm = c.MeanDbh();
  t.runs = c.runs;
  const double n = static_cast<double>(c.xy.size());
  if (n > 1) {
    double sd = 0.0, sp = 0.0;
    for (size_t k = 0; k < c.xy.size(); ++k) {
      sd += std::pow(c.dbh_cm[k] - t.dbh_cm, 2);
      sp += (c.xy[k] - t.xy_m).squaredNorm();
    }
    t.dbh_sd_cm = std::sqrt(sd / (n - 1));
    // Of the position: the root of the two coordinates' variances summed.
    t.position_sd_m = std::sqrt(sp / (n - 1));
  }
  return t;
}

// Adds a run's stems (in the first run's frame) to the clusters: each joins the cluster the
// registration matched it to in the first run, else the nearest cluster of like DBH within the
// match radius that this run has not joined yet, else starts its own.
void AddRun(const MergeOptions& o, int run, const std::vector<MapStem>& moved,
            std::vector<Cluster>* clusters) {
  std::vector<char> taken(clusters->size(), 0);
  for (const MapStem& s : moved) {
    int best = -1;
    double best_d = o.registration.match_radius_m;
    for (size_t c = 0; c < clusters->size(); ++c) {
      if (taken[c]) continue;
      const Cluster& k = (*clusters)[c];
      const double d = (k.MeanXy() - s.xy).norm();
      const double dbh = k.MeanDbh();
      const bool like =
          std::abs(dbh - s.dbh_cm) <=
          std::max(o.registration.dbh_slack_cm, o.registration.dbh_share * std::max(dbh, s.dbh_cm));
      if (like && d <= best_d) {
        best = static_cast<int>(c);
        best_d = d;
      }
    }
    if (best < 0) {
      clusters->push_back({});
      taken.push_back(0);
      best = static_cast<int>(clusters->size()) - 1;
    }
    taken[best] = 1;
    Cluster& k = (*clusters)[best];
    k.xy.push_back(s.xy);
    k.dbh_cm.push_back(s.dbh_cm);
    k.runs.push_back(run);
  }
}

}  // namespace

MergeResult MergeMaps(const MergeOptions& o, const std::vector<std::vector<MapStem>>& maps,
                      const std::vector<std::string>& names) {
  o.Check();
  if (maps.size() < 2) throw InputError("merge needs two runs or more of one plot");
  MergeResult r;
  Registration identity;
  identity.ok = true;
  identity.matched_share = 1.0;
  r.registrations.push_back(identity);
  std::vector<Cluster> clusters;
  AddRun(o, 0, maps[0], &clusters);
  for (size_t k = 1; k < maps.size(); ++k) {
    const Registration g = RegisterMaps(o.registration, maps[0], maps[k]);
    if (!g.ok || g.matched_share < o.min_matched_share || g.rms_m > o.max_rms_m) {
      throw InputError(fmt::format(
          "{} does not belong with {}: {} of its stems match ({:.0f} % of the smaller list; "
          "{:.0f} % needed) with {:.2f} m residuals: another plot, or too few stems in common",
          names[k], names[0], g.matches.size(), 100 * g.matched_share, 100 * o.min_matched_share,
          g.rms_m));
    }
    std::vector<MapStem> moved = maps[k];
    for (MapStem& s : moved) s.xy = g.Apply(s.xy);
    AddRun(o, static_cast<int>(k), moved, &clusters);
    r.registrations.push_back(g);
  }
  for (const Cluster& c : clusters) r.trees.push_back(ToTree(c));
  std::ranges::stable_sort(r.trees, [](const MergedTree& a, const MergedTree& b) {
    return a.xy_m.norm() < b.xy_m.norm();
  });
  std::vector<double> dbh_sd, pos_sd;
  for (const MergedTree& t : r.trees) {
    if (t.runs.size() < 2) continue;
    dbh_sd.push_back(t.dbh_sd_cm);
    pos_sd.push_back(t.position_sd_m);
  }
  r.median_dbh_sd_cm = Median(dbh_sd);
  r.median_position_sd_m = Median(pos_sd);
  return r;
}

nlohmann::json MergeResult::Summary() const {
  nlohmann::json runs = nlohmann::json::array();
  for (const Registration& g : registrations) {
    runs.push_back({{"yaw_deg", g.yaw_deg},
                    {"translation_m", {g.translation_m.x(), g.translation_m.y()}},
                    {"matched", g.matches.size()},
                    {"matched_share", g.matched_share},
                    {"rms_m", g.rms_m}});
  }
  int in_all = 0;
  for (const MergedTree& t : trees) in_all += t.runs.size() == registrations.size();
  return {{"runs", runs},
          {"trees", trees.size()},
          {"trees_in_every_run", in_all},
          {"median_dbh_sd_cm", median_dbh_sd_cm},
          {"median_position_sd_m", median_position_sd_m}};
}

std::vector<MapStem> ReadRunStems(const fs::path& run_dir) {
  const fs::path path = run_dir / "trees.csv";
  if (!fs::is_regular_file(path)) {
    throw InputError(fmt::format("{} has no trees.csv: a `stemmap process` run folder is needed",
                                 run_dir.string()));
  }
  const CsvTable t = ReadCsvTable(path);
  const int ix = t.Column({"x_m"}), iy = t.Column({"y_m"}), idbh = t.Column({"dbh_cm"});
  if (ix < 0 || iy < 0 || idbh < 0) {
    throw InputError(fmt::format("{} needs columns x_m, y_m and dbh_cm", path.string()));
  }
  std::vector<MapStem> stems;
  for (size_t r = 0; r < t.rows.size(); ++r) {
    stems.push_back({{t.Number(r, ix), t.Number(r, iy)}, t.Number(r, idbh)});
  }
  return stems;
}

namespace {

std::string MergedCsv(const MergeResult& r) {
  std::string s = "tree_id,x_m,y_m,dbh_cm,dbh_sd_cm,position_sd_m,n_runs,runs\n";
  int id = 0;
  for (const MergedTree& t : r.trees) {
    std::vector<int> runs1;
    for (int k : t.runs) runs1.push_back(k + 1);
    s += fmt::format("{},{:.3f},{:.3f},{:.1f},{:.2f},{:.3f},{},{}\n", ++id, t.xy_m.x(), t.xy_m.y(),
                     t.dbh_cm, t.dbh_sd_cm, t.position_sd_m, t.runs.size(), fmt::join(runs1, ";"));
  }
  return s;
}

// Every run's stems, moved into the first run's frame, each run in its own colour, over the
// merged trees' numbers: a map like the paper's cross-video overlay.
std::string OverlaySvg(const MergeResult& r, const std::vector<std::vector<MapStem>>& maps) {
  constexpr int kSize = 640;
  constexpr const char* kColours[] = {"#1b9e77", "#d95f02", "#7570b3", "#e7298a",
                                      "#66a61e", "#e6ab02", "#a6761d", "#666666"};
  double extent = 11.0;
  for (const MergedTree& t : r.trees) extent = std::max(extent, t.xy_m.norm() + 0.8);
  const double px = (kSize - 60) / (2 * extent), c = kSize / 2.0;
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{0}\" height=\"{0}\" "
      "font-family=\"sans-serif\" "
      "font-size=\"10\">\n<rect width=\"{0}\" height=\"{0}\" fill=\"#fbfbf7\"/>\n",
      kSize);
  for (double ring = 5.0; ring < extent; ring += 5.0) {
    svg += fmt::format(
        "<circle cx=\"{0}\" cy=\"{0}\" r=\"{1:.1f}\" fill=\"none\" stroke=\"#d8d8d0\"/>\n", c,
        ring * px);
  }
  for (size_t k = 0; k < maps.size(); ++k) {
    for (const MapStem& s : maps[k]) {
      const Eigen::Vector2d p = r.registrations[k].Apply(s.xy);
      svg += fmt::format(
          "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" fill=\"none\" stroke=\"{}\"/>\n",
          c + px * p.x(), c - px * p.y(), std::max(2.0, 1.5 * s.dbh_cm / 100 * px),
          kColours[k % 8]);
    }
    svg += fmt::format("<text x=\"10\" y=\"{}\" fill=\"{}\">run {}</text>\n", 16 + 13 * k,
                       kColours[k % 8], k + 1);
  }
  int id = 0;
  for (const MergedTree& t : r.trees) {
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\">{}</text>\n", c + px * t.xy_m.x() + 6,
                       c - px * t.xy_m.y() - 6, ++id);
  }
  return svg + "</svg>\n";
}

}  // namespace

MergeResult RunMerge(const MergeOptions& o, const std::vector<fs::path>& runs,
                     const fs::path& out_dir) {
  o.Check();
  std::vector<std::vector<MapStem>> maps;
  std::vector<std::string> names;
  for (const fs::path& run : runs) {
    maps.push_back(ReadRunStems(run));
    names.push_back(run.string());
  }
  const MergeResult r = MergeMaps(o, maps, names);
  fs::create_directories(out_dir);
  WriteFileAtomic(out_dir / "merged_trees.csv", MergedCsv(r));
  nlohmann::json summary = r.Summary();
  for (size_t k = 0; k < runs.size(); ++k) {
    summary["runs"][k]["run"] = fs::absolute(runs[k]).string();
  }
  summary["options"] = o;
  WriteJsonAtomic(out_dir / "merge.json", summary);
  WriteFileAtomic(out_dir / "merge_map.svg", OverlaySvg(r, maps));
  return r;
}

}  // namespace stemmap::merge
