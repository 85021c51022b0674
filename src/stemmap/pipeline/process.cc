#include "stemmap/pipeline/process.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/pose.h"
#include "stemmap/core/run_folder.h"
#include "stemmap/dense/cloud_io.h"
#include "stemmap/gis/gis_files.h"
#include "stemmap/gis/las.h"
#include "stemmap/gis/tree_table.h"
#include "stemmap/report/report.h"
#include "stemmap/track/track_io.h"

namespace stemmap::pipeline {

void ProcessOptions::Check() const {
  track.Check();
  dense.Check();
  measure.Check();
  if (!mask.model.empty()) mask.Check();
  if (!(plot_radius_m > 0)) throw InputError("--plot-radius must be positive");
  georef.Check();
}

namespace {

// The camera centres of every tracked frame (keyframes where frames were not kept), plot frame.
std::vector<Eigen::Vector2d> CameraPathXy(const track::TrackResult& tr) {
  std::vector<Eigen::Vector2d> xy;
  for (const StampedPose& p : tr.frames.empty() ? tr.keyframes : tr.frames) {
    xy.push_back(p.world_from_cam.translation.head<2>());
  }
  return xy;
}

// The run as the report's metadata block shows it: what was filmed and how, and where the plot
// lies.
std::vector<std::pair<std::string, std::string>> RunMetadata(const ProcessOptions& o,
                                                             const nlohmann::json& summary,
                                                             const std::filesystem::path& video) {
  auto number = [&](const char* stage, const char* key, const char* format) -> std::string {
    const auto s = summary.find(stage);
    if (s == summary.end() || !s->contains(key) || !(*s)[key].is_number()) return "unknown";
    return fmt::format(fmt::runtime(format), (*s)[key].get<double>());
  };
  std::string recorded = "not in the video file";
  if (summary.contains("track") && summary["track"].contains("video")) {
    const nlohmann::json& v = summary["track"]["video"];
    if (v.contains("creation_time") && v["creation_time"].is_string() &&
        !v["creation_time"].get<std::string>().empty()) {
      recorded = v["creation_time"].get<std::string>();
    }
  }
  std::vector<std::pair<std::string, std::string>> m = {
      {"video", video.filename().string()},
      {"recorded", recorded},
      {"stemmap", STEMMAP_VERSION},
      {"arm radius", number("track", "arm_radius_m", "{:.2f} m")},
      {"camera height above the ground", number("track", "camera_height_m", "{:.2f} m")},
      {"horizontal field of view", number("track", "hfov_deg", "{:.1f}°")},
      {"turn tracked", number("track", "turn_deg", "{:.0f}°")},
      {"ground slope", number("stems", "ground_slope_deg", "{:.1f}°")},
      {"plot radius (horizontal)", fmt::format("{:g} m", o.plot_radius_m)},
      {"breast height", fmt::format("{:g} m", o.measure.stems.breast_height_m)},
      {"smallest DBH counted", fmt::format("{:g} cm", o.measure.min_dbh_cm)},
      {"DBH method", std::string(stems::DbhMethodName(o.measure.stems.dbh_method))}};
  const gis::GeoreferenceOptions& g = o.georef;
  if (g.HasLatLonCentre()) {
    m.emplace_back("plot centre (WGS 84)",
                   fmt::format("{:.7f}, {:.7f}", *g.centre_lat_deg, *g.centre_lon_deg));
  } else if (g.HasProjectedCentre()) {
    m.emplace_back("plot centre", fmt::format("E {:.2f}, N {:.2f} ({})", *g.centre_easting_m,
                                              *g.centre_northing_m, g.crs));
  }
  if (g.first_bearing_deg) {
    m.emplace_back(
        "bearing of the first view",
        fmt::format("{:.1f}° (declination {:+.1f}°)", *g.first_bearing_deg, g.declination_deg));
  }
  return m;
}

std::vector<std::pair<std::string, std::string>> FigureRows(const ProcessOptions& o,
                                                            const ProcessResult& r) {
  const stems::PlotFigures& f = r.figures;
  const stems::OcclusionCorrection& oc = f.occlusion;
  return {
      {"stems listed (within 11 m)", fmt::format("{}", r.stems.size())},
      {fmt::format("stems in the {:g}-m plot, DBH ≥ {:g} cm", o.plot_radius_m,
                   o.measure.min_dbh_cm),
       fmt::format("{} ({} borderline, {} of them counted)", f.stems, f.borderline_stems,
                   f.borderline_counted)},
      {"stems per hectare (95 % interval)",
       fmt::format("{:.0f} ({:.0f}-{:.0f})", f.stems_per_ha, f.stems_per_ha_95.low,
                   f.stems_per_ha_95.high)},
      {"basal area (95 % interval)",
       fmt::format("{:.1f} m²/ha ({:.1f}-{:.1f})", f.basal_area_m2_per_ha,
                   f.basal_area_m2_per_ha_95.low, f.basal_area_m2_per_ha_95.high)},
      {"quadratic mean diameter (95 % interval)",
       fmt::format("{:.1f} cm ({:.1f}-{:.1f})", f.qmd_cm, f.qmd_cm_95.low, f.qmd_cm_95.high)},
      {"dominant diameter, 100 thickest/ha (95 % interval)",
       fmt::format("{:.1f} cm ({:.1f}-{:.1f})", f.dominant_diameter_cm,
                   f.dominant_diameter_cm_95.low, f.dominant_diameter_cm_95.high)},
      {"stems expected behind nearer ones", fmt::format("{:.1f}", f.expected_hidden_stems)},
      {fmt::format("corrected for occlusion ({})", stems::DetectionModelName(oc.fit.model)),
       fmt::format("{:.0f} stems/ha ({:.0f}-{:.0f}), {:.1f} m²/ha ({:.1f}-{:.1f})", oc.stems_per_ha,
                   oc.stems_per_ha_95.low, oc.stems_per_ha_95.high, oc.basal_area_m2_per_ha,
                   oc.basal_area_m2_per_ha_95.low, oc.basal_area_m2_per_ha_95.high)}};
}

void WriteProcessReport(const ProcessOptions& o, const TreeOutputsInput& tin,
                        const stems::Visibility& visibility, const ProcessResult& r,
                        const std::filesystem::path& out_dir) {
  const track::TrackResult& tr = *tin.track;
  report::ReportOptions ro;
  ro.map.plot_radius_m = o.plot_radius_m;
  if (o.georef.first_bearing_deg) {
    ro.map.north_azimuth_deg = *o.georef.first_bearing_deg + o.georef.declination_deg;
  }
  ro.breast_height_m = o.measure.stems.breast_height_m;
  report::ReportInput in;
  in.stems = &r.stems;
  in.camera = &tr.camera;
  in.keyframes = &tr.keyframes;
  in.images = tin.images;
  in.camera_path_xy = CameraPathXy(tr);
  in.title = fmt::format("stemmap plot report: {}", tin.video.filename().string());
  in.metadata = RunMetadata(o, r.summary, tin.video);
  in.figures = FigureRows(o, r);
  in.stand_table = r.figures.stand_table;
  in.hidden = visibility.sectors;
  report::WriteReport(ro, in, out_dir);
}

// Where a finished run's file is needed by a later one: hard-linked when the file system allows
// (the cloud is large), else copied.
void LinkOrCopy(const std::filesystem::path& from, const std::filesystem::path& to) {
  std::error_code ec;
  std::filesystem::create_hard_link(from, to, ec);
  if (ec) std::filesystem::copy_file(from, to, std::filesystem::copy_options::overwrite_existing);
}

// The cloud of a finished run (`dir`), with its coarse points and depth focal length.
struct SavedCloud {
  std::vector<dense::CloudPoint> points, coarse;
  nlohmann::json summary;
  double depth_focal_px = 0.0;
};
SavedCloud ReadSavedCloud(const std::filesystem::path& dir) {
  for (const char* name : {"cloud.ply", "cloud_coarse.ply", "dense_summary.json"}) {
    if (!std::filesystem::is_regular_file(dir / name)) {
      throw InputError(fmt::format(
          "{} has no {}: `stems --from` needs the folder of a finished `stemmap process` run",
          dir.string(), name));
    }
  }
  SavedCloud c;
  c.points = dense::ReadCloudPly(dir / "cloud.ply");
  c.coarse = dense::ReadCloudPly(dir / "cloud_coarse.ply");
  c.summary = ReadJsonFile(dir / "dense_summary.json");
  const auto focal = c.summary.find("depth_focal_px");
  if (focal == c.summary.end() || !focal->is_number() || !(focal->get<double>() >= 0)) {
    throw InputError(fmt::format("{}: no depth_focal_px", (dir / "dense_summary.json").string()));
  }
  c.depth_focal_px = focal->get<double>();
  return c;
}

}  // namespace

void WriteTreeOutputs(const ProcessOptions& o, const TreeOutputsInput& in,
                      const std::filesystem::path& out_dir, ProcessResult* r) {
  const track::TrackResult& tr = *in.track;
  const stems::Visibility visibility =
      stems::HiddenBehindStems(r->stems, tr.keyframes, tr.camera, o.plot_radius_m);
  stems::PlotFigureOptions figure_options;
  figure_options.plot_radius_m = o.plot_radius_m;
  figure_options.min_dbh_cm = o.measure.min_dbh_cm;
  r->figures = stems::ComputePlotFigures(figure_options, r->stems, visibility);
  gis::TreeRowOptions row_options;
  row_options.breast_height_m = o.measure.stems.breast_height_m;
  row_options.plot_radius_m = o.plot_radius_m;
  const std::vector<gis::TreeRow> rows = gis::TreeRows(row_options, r->stems, *in.georef);
  gis::WriteTreesCsv(out_dir / "trees.csv", rows);
  for (const gis::TreeTableFormat format : o.exports) {
    gis::WriteTreeTable(format, out_dir / gis::TreeTableFileName(format), rows,
                        in.video.stem().string(), in.video.filename().string());
  }
  WriteStemDetails(out_dir / "stems_detail.csv", r->stems);
  WriteStandTableCsv(out_dir / "stand_table.csv", r->figures);
  gis::WriteGisFiles(*in.georef, {&rows, CameraPathXy(tr), o.plot_radius_m}, out_dir);
  std::vector<double> keyframe_t_s;
  for (const StampedPose& k : tr.keyframes) keyframe_t_s.push_back(k.t_s);
  gis::WriteLas(out_dir / "cloud.las", *in.cloud, keyframe_t_s, *in.georef);
  if (o.write_report) WriteProcessReport(o, in, visibility, *r, out_dir);
  r->summary["plot"] = PlotSummaryJson(r->figures, visibility, static_cast<int>(r->stems.size()),
                                       o.plot_radius_m, o.measure.min_dbh_cm);
  r->summary["georeference"] = o.georef;
  r->summary["georeference"]["gis_crs"] = in.georef->Describe();
  for (const auto& w : r->summary["plot"]["warnings"]) spdlog::warn("{}", w.get<std::string>());
}

ProcessResult RunStems(const ProcessOptions& o, const std::filesystem::path& video,
                       const std::filesystem::path& from_dir, const std::filesystem::path& out) {
  o.Check();
  const gis::Georeference georef(o.georef);  // an unknown CRS fails here, before any work
  StagedRunFolder folder(out);
  const std::filesystem::path& out_dir = folder.staging();
  const auto t0 = std::chrono::steady_clock::now();
  const SavedCloud cloud = ReadSavedCloud(from_dir);
  track::TrackResult tr = track::LoadTrack(from_dir, video, /*full_gray=*/true);
  std::filesystem::create_directories(out_dir);
  // The folder can be gone on from in turn: the track and the cloud come along.
  WriteTumTrajectory(out_dir / "keyframes.tum", tr.keyframes);
  WriteTumTrajectory(out_dir / "trajectory.tum", tr.frames.empty() ? tr.keyframes : tr.frames);
  for (const char* name : {"cloud.ply", "cloud_coarse.ply", "dense_summary.json"}) {
    LinkOrCopy(from_dir / name, out_dir / name);
  }
  stems::MeasureInput min{&cloud.points,
                          &cloud.coarse,
                          cloud.depth_focal_px,
                          &tr.camera,
                          &tr.keyframes,
                          &tr.keyframe_images,
                          std::move(tr.keyframe_gray_full)};
  stems::MeasureResult mr = stems::MeasureTrees(o.measure, std::move(min));
  ProcessResult r;
  r.stems = std::move(mr.trees);
  nlohmann::json& s = r.summary;
  tr.summary["reused_from"] = std::filesystem::absolute(from_dir).string();
  s["track"] = tr.summary;
  s["dense"] = cloud.summary;
  s["stems"] = mr.summary;
  WriteTreeOutputs(o, {&tr, &tr.keyframe_images, &cloud.points, &georef, video}, out_dir, &r);
  s["timing_s"] = {
      {"stems_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()}};
  WriteJsonAtomic(out_dir / "process_options.json", o);
  WriteJsonAtomic(out_dir / "summary.json", s);
  folder.Commit({{"command", "stems"},
                 {"video", std::filesystem::absolute(video).string()},
                 {"from", std::filesystem::absolute(from_dir).string()}});
  return r;
}

ProcessResult RunProcess(const ProcessOptions& o, const std::filesystem::path& video,
                         const std::filesystem::path& out) {
  o.Check();
  const gis::Georeference georef(o.georef);  // an unknown CRS fails here, before any work
  // Everything is written to a staging folder and moved into `out` at the end; an unusable
  // `out` is refused here, before the long work.
  StagedRunFolder folder(out, o.from_track);
  const std::filesystem::path& out_dir = folder.staging();
  const auto t0 = std::chrono::steady_clock::now();
  auto lap = [last = t0]() mutable {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - last).count();
    last = now;
    return s;
  };
  nlohmann::json timing;
  // A bad model file fails before the long work starts.
  std::unique_ptr<dense::TrunkMaskModel> mask_model;
  if (!o.mask.model.empty()) {
    mask_model = dense::LoadDnnMaskModel(o.mask);
    spdlog::info("trunk mask model: {}", mask_model->Describe());
  }
  // The front end keeps the keyframe images: the video is decoded once.
  track::TrackOptions topt = o.track;
  topt.frontend.keep_keyframe_images = true;
  track::TrackResult tr;
  if (o.from_track.empty()) {
    tr = track::TrackInto(topt, video, out_dir);
    // What a stop from here on leaves is a finished track, and how to go on from it.
    folder.KeepIfUnfinished();
    SetInterruptMessage(fmt::format(
        "interrupted after tracking: {} is unchanged; the finished track is in {} (go on with "
        "`stemmap process {} --from-track {} --out {}`)",
        out.string(), out_dir.string(), video.string(), out_dir.string(), out.string()));
  } else {
    tr = track::LoadTrack(o.from_track, video, /*full_gray=*/true);
    std::filesystem::create_directories(out_dir);
    WriteTumTrajectory(out_dir / "keyframes.tum", tr.keyframes);
    WriteTumTrajectory(out_dir / "trajectory.tum", tr.frames.empty() ? tr.keyframes : tr.frames);
    tr.summary["reused_from"] = std::filesystem::absolute(o.from_track).string();
  }
  timing["track_s"] = lap();
  dense::DenseInput din{tr.camera, tr.keyframes, std::move(tr.keyframe_images)};
  if (mask_model) din.mask_model = mask_model.get();
  const dense::DenseResult dr = dense::RunDense(o.dense, din, out_dir);
  timing["dense_s"] = lap();
  stems::MeasureInput min{
      &dr.points,  &dr.short_baseline_points,       dr.depth_focal_px, &tr.camera, &tr.keyframes,
      &din.images, std::move(tr.keyframe_gray_full)};
  stems::MeasureResult mr = stems::MeasureTrees(o.measure, std::move(min));
  timing["stems_s"] = lap();

  ProcessResult r;
  r.stems = std::move(mr.trees);
  nlohmann::json& s = r.summary;
  s["track"] = tr.summary;
  s["dense"] = dr.summary;
  s["stems"] = mr.summary;
  WriteTreeOutputs(o, {&tr, &din.images, &dr.points, &georef, video}, out_dir, &r);
  timing["total_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s["timing_s"] = timing;
  WriteJsonAtomic(out_dir / "process_options.json", o);
  WriteJsonAtomic(out_dir / "summary.json", s);
  folder.Commit({{"command", "process"}, {"video", std::filesystem::absolute(video).string()}});
  return r;
}

}  // namespace stemmap::pipeline
