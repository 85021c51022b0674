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
#include "stemmap/pipeline/refine.h"
#include "stemmap/report/report.h"
#include "stemmap/track/track_io.h"

namespace stemmap::pipeline {

void ProcessOptions::Check() const {
  track.Check();
  dense.Check();
  stems.Check();
  bark_depth.Check();
  if (!mask.model.empty()) mask.Check();
  if (!(plot_radius_m > 0)) throw InputError("--plot-radius must be positive");
  if (min_dbh_cm < 0) throw InputError("--min-dbh must not be negative");
  if (!(one_sided_min_cloud_radius_m >= 0)) {
    throw InputError("the cloud radius a one-sided fit may widen must not be negative");
  }
  if (!(one_sided_max_over_cloud >= 1)) {
    throw InputError("a one-sided fit's bound over the cloud's width must be at least 1");
  }
  if (!(min_bark_gap_m >= 0 && min_bark_gap_m < 1)) {
    throw InputError("the smallest gap between two stems' bark must lie in [0, 1) m");
  }
  if (!(larger_cloud_part_gap_m >= 0)) {
    throw InputError(
        "the gap within which a larger cloud's part joins a stem must not be negative");
  }
  if (!(larger_cloud_only_max_rms_px >= 0)) {
    throw InputError("the rms a larger cloud's stem's silhouettes may keep must not be negative");
  }
  if (!(wide_fit_scale >= 1)) {
    throw InputError(
        "the width over the cloud's that needs the bark to line up must be at least 1");
  }
  if (!(wide_fit_min_bark_ncc >= -1 && wide_fit_min_bark_ncc <= 1)) {
    throw InputError("the bark correlation a wide fit needs must lie in [-1, 1]");
  }
  if (!(narrow_fit_share >= 0 && narrow_fit_share <= 1)) {
    throw InputError(
        "the share of a part's width below which its cores are tried must lie in [0, 1]");
  }
  if (!(min_core_share >= 0 && min_core_share <= 1)) {
    throw InputError("the share of a part's width a core must reach must lie in [0, 1]");
  }
}

namespace {

void WriteProcessReport(const ProcessOptions& o, const track::TrackResult& tr,
                        const std::vector<cv::Mat>& images, const ProcessResult& r,
                        const std::filesystem::path& video, const std::filesystem::path& out_dir) {
  report::ReportOptions ro;
  ro.map.plot_radius_m = o.plot_radius_m;
  ro.breast_height_m = o.stems.breast_height_m;
  report::ReportInput in;
  in.stems = &r.stems;
  in.camera = &tr.camera;
  in.keyframes = &tr.keyframes;
  in.images = &images;
  for (const StampedPose& p : tr.frames.empty() ? tr.keyframes : tr.frames) {
    in.camera_path_xy.push_back(p.world_from_cam.translation.head<2>());
  }
  in.title = fmt::format("stemmap plot report: {}", video.filename().string());
  const PlotFigures& f = r.figures;
  in.figures = {
      {"stems listed (within 11 m)", fmt::format("{}", r.stems.size())},
      {fmt::format("stems in the {:g}-m plot, DBH ≥ {:g} cm", o.plot_radius_m, o.min_dbh_cm),
       fmt::format("{}", f.stems)},
      {"stems per hectare", fmt::format("{:.0f}", f.stems_per_ha)},
      {"basal area", fmt::format("{:.1f} m²/ha", f.basal_area_m2_per_ha)},
      {"quadratic mean diameter", fmt::format("{:.1f} cm", f.qmd_cm)},
      {"DBH method", o.stems.dbh_method}};
  report::WriteReport(ro, in, out_dir);
}

}  // namespace

ProcessResult RunProcess(const ProcessOptions& o, const std::filesystem::path& video,
                         const std::filesystem::path& out) {
  o.Check();
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
  const stems::GroundGrid ground(dr.points, o.stems.search_radius_m + 2.0, 0.5);
  stems::StemsResult sr = stems::DetectStems(o.stems, dr.points, ground, dr.depth_focal_px);
  std::vector<stems::Stem> larger_only;
  if (!dr.short_baseline_points.empty()) {
    // The short-baseline points only give a second start to parts that come to nothing; the
    // silhouettes and the bark judge it like any other.
    std::vector<dense::CloudPoint> all = dr.points;
    all.insert(all.end(), dr.short_baseline_points.begin(), dr.short_baseline_points.end());
    stems::StemsResult more = stems::DetectStems(o.stems, all, ground, dr.depth_focal_px);
    if (o.larger_cloud_only_max_rms_px > 0) {
      // Where the cloud has no part at all, the larger cloud's stems, vetoed or not: the coarse
      // points of a stem seen past a nearer one for a short turn often smear into its free space.
      std::vector<stems::Stem> candidates = std::move(more.vetoed);
      candidates.insert(candidates.end(), more.stems.begin(), more.stems.end());
      larger_only = stems::StemsAwayFrom(candidates, o.larger_cloud_part_gap_m, sr.stems);
      sr.larger_cloud_only = static_cast<int>(larger_only.size());
    }
    sr.larger_cloud_parts =
        stems::AttachLargerCloudParts(std::move(more.stems), o.larger_cloud_part_gap_m, &sr.stems);
  }
  timing["stems_s"] = lap();
  RefineWithTangentRays(o, tr, std::move(tr.keyframe_gray_full), din.images, &sr.stems,
                        std::move(larger_only));
  timing["tangent_rays_s"] = lap();
  // Stems below the calliper threshold are not trees of the list (a fit that closed on a twig).
  const size_t below =
      std::erase_if(sr.stems, [&](const stems::Stem& s) { return 100 * s.dbh_m < o.min_dbh_cm; });
  if (below > 0) spdlog::info("stems: {} below {:.0f} cm DBH left out", below, o.min_dbh_cm);
  // tree_id counts outward (docs/output-format.md): fits move stems, and stems found late join.
  std::ranges::stable_sort(sr.stems, stems::NearerTheCentre);

  ProcessResult r;
  r.stems = sr.stems;
  r.figures = ComputePlotFigures(r.stems, o.plot_radius_m, o.min_dbh_cm);
  WriteTreesCsv(out_dir / "trees.csv", r.stems, o.stems.breast_height_m, o.plot_radius_m);
  WriteStemDetails(out_dir / "stems_detail.csv", r.stems);
  if (o.write_report) WriteProcessReport(o, tr, din.images, r, video, out_dir);
  nlohmann::json& s = r.summary;
  s["plot"] =
      PlotSummaryJson(r.figures, static_cast<int>(r.stems.size()), o.plot_radius_m, o.min_dbh_cm);
  for (const auto& w : s["plot"]["warnings"]) spdlog::warn("{}", w.get<std::string>());
  s["track"] = tr.summary;
  s["dense"] = dr.summary;
  s["stems"] = sr.Summary();
  s["stems"]["dbh_method"] = o.stems.dbh_method;
  s["stems"]["ground_cells"] = ground.measured_cells();
  timing["total_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s["timing_s"] = timing;
  WriteJsonAtomic(out_dir / "process_options.json", o);
  WriteJsonAtomic(out_dir / "summary.json", s);
  folder.Commit({{"command", "process"}, {"video", std::filesystem::absolute(video).string()}});
  return r;
}

}  // namespace stemmap::pipeline
