#include "stemmap/batch/batch.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <set>
#include <sstream>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/gis/gis_files.h"
#include "stemmap/merge/csv.h"

namespace stemmap::batch {

namespace fs = std::filesystem;

namespace {

constexpr const char* kColumns[] = {"plot_id",  "video",       "arm_radius_m",
                                    "hfov_deg", "calibration", "camera_height_m",
                                    "vertical", "plot_centre", "first_bearing_deg"};

// Sets the row's cells on top of the defaults; an empty cell keeps the default.
void ApplyCells(const merge::CsvTable& t, size_t r, const fs::path& base, PlotRow* row) {
  auto cell = [&](const char* name) -> std::string {
    const int c = t.Column({name});
    return c >= 0 && c < static_cast<int>(t.rows[r].size()) ? t.rows[r][c] : "";
  };
  auto number = [&](const char* name, auto* target) {
    if (!cell(name).empty()) *target = t.Number(r, t.Column({name}));
  };
  track::TrackOptions& track = row->options.track;
  number("arm_radius_m", &track.arm_radius_m);
  number("hfov_deg", &track.hfov_deg);
  number("camera_height_m", &track.camera_height_m);
  if (!cell("calibration").empty()) track.calibration = base / cell("calibration");
  if (!cell("vertical").empty()) {
    try {
      track.vertical_from = EnumFromName(track::kVerticalSourceNames, cell("vertical"), "vertical");
    } catch (const InputError& e) {
      throw InputError(fmt::format("{} line {}: {}", t.path.string(), t.line_numbers[r], e.what()));
    }
  }
  gis::GeoreferenceOptions& g = row->options.georef;
  if (!cell("first_bearing_deg").empty()) {
    g.first_bearing_deg = t.Number(r, t.Column({"first_bearing_deg"}));
  }
  const std::string centre = cell("plot_centre");
  if (!centre.empty()) {
    std::istringstream in(centre);
    double lat = 0, lon = 0;
    std::string rest;
    if (!(in >> lat >> lon) || (in >> rest)) {
      throw InputError(fmt::format("{} line {}: plot_centre must be `LAT LON`, not '{}'",
                                   t.path.string(), t.line_numbers[r], centre));
    }
    g.centre_lat_deg = lat;
    g.centre_lon_deg = lon;
  }
}

bool PlainName(const std::string& id) {
  return !id.empty() && id != "." && id != ".." && std::ranges::all_of(id, [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.';
  });
}

}  // namespace

std::vector<PlotRow> ReadManifest(const fs::path& manifest,
                                  const pipeline::ProcessOptions& defaults) {
  const merge::CsvTable t = merge::ReadCsvTable(manifest);
  for (const char* name : {"plot_id", "video"}) {
    if (t.Column({name}) < 0) {
      throw InputError(fmt::format("{} has no {} column (the columns: {})", manifest.string(), name,
                                   fmt::join(kColumns, ",")));
    }
  }
  for (const std::string& h : t.header) {
    if (std::ranges::find(kColumns, h) == std::end(kColumns)) {
      throw InputError(fmt::format("{}: unknown column '{}' (the columns: {})", manifest.string(),
                                   h, fmt::join(kColumns, ",")));
    }
  }
  const fs::path base = manifest.parent_path();
  std::vector<PlotRow> rows;
  std::set<std::string> ids;
  for (size_t r = 0; r < t.rows.size(); ++r) {
    PlotRow row;
    row.line = t.line_numbers[r];
    row.options = defaults;
    row.plot_id = t.rows[r][t.Column({"plot_id"})];
    if (!PlainName(row.plot_id) || !ids.insert(row.plot_id).second) {
      throw InputError(fmt::format(
          "{} line {}: plot_id '{}' must be a plain name (letters, digits, - _ .) given once",
          manifest.string(), row.line, row.plot_id));
    }
    const int v = t.Column({"video"});
    if (v >= static_cast<int>(t.rows[r].size()) || t.rows[r][v].empty()) {
      throw InputError(fmt::format("{} line {}: no video", manifest.string(), row.line));
    }
    row.video = base / t.rows[r][v];
    ApplyCells(t, r, base, &row);
    try {
      row.options.Check();
    } catch (const InputError& e) {
      throw InputError(fmt::format("{} line {}: {}", manifest.string(), row.line, e.what()));
    }
    rows.push_back(std::move(row));
  }
  if (rows.empty()) throw InputError(fmt::format("{} lists no plot", manifest.string()));
  return rows;
}

namespace {

bool Finished(const fs::path& dir) { return fs::is_regular_file(dir / "stemmap_run.json"); }

// Runs one plot: its folder when it finishes, its message in OUT/<id>.failed.json when not.
PlotOutcome RunPlot(const PlotRow& row, const fs::path& out_dir) {
  PlotOutcome o;
  o.plot_id = row.plot_id;
  const fs::path dir = out_dir / row.plot_id;
  const fs::path failed = out_dir / (row.plot_id + ".failed.json");
  if (Finished(dir)) {
    o.status = PlotStatus::kFinished;
    return o;
  }
  o.ran_now = true;
  try {
    pipeline::RunProcess(row.options, row.video, dir);
    o.status = PlotStatus::kFinished;
    std::error_code ec;
    fs::remove(failed, ec);
  } catch (const std::exception& e) {
    o.status = PlotStatus::kFailed;
    o.message = e.what();
    spdlog::error("plot {}: {}", row.plot_id, o.message);
    WriteJsonAtomic(
        failed, {{"plot_id", row.plot_id}, {"video", row.video.string()}, {"message", o.message}});
  }
  return o;
}

PlotOutcome StatusOf(const PlotRow& row, const fs::path& out_dir) {
  PlotOutcome o;
  o.plot_id = row.plot_id;
  const fs::path failed = out_dir / (row.plot_id + ".failed.json");
  if (Finished(out_dir / row.plot_id)) {
    o.status = PlotStatus::kFinished;
  } else if (fs::is_regular_file(failed)) {
    o.status = PlotStatus::kFailed;
    const nlohmann::json j = ReadJsonFile(failed);
    o.message = j.value("message", std::string("failed"));
  }
  return o;
}

// OUT/batch_summary.csv and OUT/plots.gpkg from the plots' own folders.
void WriteSummary(const std::vector<PlotRow>& rows, const std::vector<PlotOutcome>& outcomes,
                  const fs::path& out_dir) {
  std::string csv =
      "plot_id,status,stems,stems_per_ha,basal_area_m2_per_ha,qmd_cm,lat,lon,message\n";
  std::vector<gis::InventoryPlot> plots;
  std::vector<gis::InventoryTree> trees;
  for (size_t k = 0; k < rows.size(); ++k) {
    const PlotOutcome& o = outcomes[k];
    const char* status = o.status == PlotStatus::kFinished ? "finished"
                         : o.status == PlotStatus::kFailed ? "failed"
                                                           : "pending";
    std::string message = o.message;
    std::ranges::replace(message, ',', ';');
    std::ranges::replace(message, '\n', ' ');
    if (o.status != PlotStatus::kFinished) {
      csv += fmt::format("{},{},,,,,,,{}\n", o.plot_id, status, message);
      continue;
    }
    const fs::path dir = out_dir / o.plot_id;
    const nlohmann::json plot = ReadJsonFile(dir / "summary.json").at("plot");
    const gis::GeoreferenceOptions& g = rows[k].options.georef;
    gis::InventoryPlot p{o.plot_id,
                         g.centre_lat_deg.value_or(0.0),
                         g.centre_lon_deg.value_or(0.0),
                         plot.at("stems").get<int>(),
                         plot.at("stems_per_ha").get<double>(),
                         plot.at("basal_area_m2_per_ha").get<double>(),
                         plot.at("qmd_cm").get<double>()};
    const bool placed = g.HasLatLonCentre();
    csv += fmt::format("{},finished,{},{:.1f},{:.3f},{:.1f},{},{},\n", o.plot_id, p.stems,
                       p.stems_per_ha, p.basal_area_m2_per_ha, p.qmd_cm,
                       placed ? fmt::format("{:.7f}", p.lat_deg) : "",
                       placed ? fmt::format("{:.7f}", p.lon_deg) : "");
    if (!placed) continue;
    plots.push_back(p);
    const merge::CsvTable t = merge::ReadCsvTable(dir / "trees.csv");
    const int id = t.Column({"tree_id"}), lat = t.Column({"lat"}), lon = t.Column({"lon"});
    const int dbh = t.Column({"dbh_cm"}), sd = t.Column({"dbh_sd_cm"});
    for (size_t r = 0; r < t.rows.size(); ++r) {
      trees.push_back({o.plot_id, static_cast<int>(t.Number(r, id)), t.Number(r, lat),
                       t.Number(r, lon), t.Number(r, dbh), t.Number(r, sd)});
    }
  }
  WriteFileAtomic(out_dir / "batch_summary.csv", csv);
  gis::WriteInventoryGeoPackage(out_dir / "plots.gpkg", plots, trees);
}

}  // namespace

BatchSummary RunBatch(const BatchOptions& o, const fs::path& manifest, const fs::path& out_dir) {
  const std::vector<PlotRow> rows = ReadManifest(manifest, o.process);
  if (o.task && (*o.task < 1 || *o.task > static_cast<int>(rows.size()))) {
    throw InputError(
        fmt::format("--task {}: the manifest lists plots 1 to {}", *o.task, rows.size()));
  }
  fs::create_directories(out_dir);
  BatchSummary s;
  for (size_t k = 0; k < rows.size(); ++k) {
    const bool mine = !o.summary_only && (!o.task || static_cast<int>(k) + 1 == *o.task);
    if (mine && !Finished(out_dir / rows[k].plot_id)) {
      spdlog::info("batch: plot {} of {}: {}", k + 1, rows.size(), rows[k].plot_id);
    }
    PlotOutcome outcome = mine ? RunPlot(rows[k], out_dir) : StatusOf(rows[k], out_dir);
    s.finished += outcome.status == PlotStatus::kFinished;
    s.failed += outcome.status == PlotStatus::kFailed;
    s.pending += outcome.status == PlotStatus::kPending;
    s.ran_now += outcome.ran_now;
    s.plots.push_back(std::move(outcome));
  }
  if (!o.task) WriteSummary(rows, s.plots, out_dir);
  return s;
}

}  // namespace stemmap::batch
