#include <fmt/format.h>

#include <filesystem>
#include <memory>

#include "stemmap/cli/commands.h"
#include "stemmap/core/io.h"
#include "stemmap/pipeline/process.h"

namespace stemmap::cli {

namespace {

// Where the plot lies on the map (docs/output-format.md, "Georeference").
void AddGeoreferenceFlags(CLI::App* sub, gis::GeoreferenceOptions* g) {
  sub->add_option_function<std::vector<double>>(
         "--plot-centre",
         [g](const std::vector<double>& v) {
           g->centre_lat_deg = v[0];
           g->centre_lon_deg = v[1];
         },
         "Plot centre in WGS 84, LAT,LON in degrees (a GPS reading); needs --first-bearing. The "
         "GIS files are then in WGS 84, the projected columns and cloud.las in the UTM zone")
      ->delimiter(',')
      ->expected(2);
  sub->add_option_function<std::vector<double>>(
         "--plot-centre-xy",
         [g](const std::vector<double>& v) {
           g->centre_easting_m = v[0];
           g->centre_northing_m = v[1];
         },
         "Plot centre in a projected CRS, E,N in metres; needs --crs and --first-bearing")
      ->delimiter(',')
      ->expected(2);
  sub->add_option("--crs", g->crs, "CRS of --plot-centre-xy, e.g. EPSG:25830 (metres)");
  sub->add_option_function<double>(
      "--first-bearing", [g](double v) { g->first_bearing_deg = v; },
      "Compass bearing of the first frame's view, degrees clockwise from north; fills "
      "bearing_deg and turns the map to north");
  sub->add_option("--declination", g->declination_deg,
                  "Magnetic declination, degrees east positive, when --first-bearing was read off "
                  "a magnetic compass")
      ->capture_default_str();
}

// The tree list's own flags, shared by process and stems.
void AddMeasureFlags(CLI::App* sub, pipeline::ProcessOptions* opt) {
  sub->add_option("--plot-radius", opt->plot_radius_m, "Plot radius for the plot figures (m)")
      ->capture_default_str();
  sub->add_option("--min-dbh", opt->measure.min_dbh_cm, "Smallest DBH listed and counted (cm)")
      ->capture_default_str();
  sub->add_option("--breast-height", opt->measure.stems.breast_height_m,
                  "Height of the DBH above the ground at the stem (m)")
      ->capture_default_str();
  AddEnumOption(sub, "--dbh-method", &opt->measure.stems.dbh_method, stems::kDbhMethodNames,
                "tangent (rays tangent to the silhouettes in every view; the slice width where "
                "none fit), slice (robust width of a 0.1 m slice across the view) or circle "
                "(fitted to that slice)");
  sub->add_flag("--require-silhouette,!--keep-unconfirmed", opt->measure.require_silhouette,
                "Drop cloud parts whose silhouettes were not found (default); "
                "--keep-unconfirmed keeps them, flagged no_silhouette");
  AddGeoreferenceFlags(sub, &opt->georef);
  sub->add_option_function<std::vector<std::string>>(
         "--export",
         [opt](const std::vector<std::string>& names) {
           opt->exports.clear();
           for (const std::string& name : names) {
             if (name == "fortls") {
               opt->exports.push_back(gis::TreeTableFormat::kFortls);
             } else if (name == "fsct") {
               opt->exports.push_back(gis::TreeTableFormat::kFsct);
             } else {
               throw CLI::ValidationError("--export", "fortls or fsct, not '" + name + "'");
             }
           }
         },
         "Also write the tree list as another tool's table: fortls (tree.tls.csv) or fsct "
         "(tree_data.csv); fortls,fsct for both")
      ->delimiter(',');
  sub->add_flag("--report,!--no-report", opt->write_report,
                "Write map.svg and report.html with a picture of each stem at breast height "
                "(default)");
}

}  // namespace

void AddProcessCommand(CLI::App& app) {
  auto opt = std::make_shared<pipeline::ProcessOptions>();
  auto video = std::make_shared<std::filesystem::path>();
  auto out = std::make_shared<std::filesystem::path>();
  CLI::App* sub = app.add_subcommand(
      "process", "Tree list of a capture video: positions and DBH (trees.csv, summary.json)");
  AddTrackOptions(sub, &opt->track, video.get(), out.get());
  CLI::Option* from_track =
      sub->add_option("--from-track", opt->from_track,
                      "Reuse the keyframe poses and camera of an earlier track or process run "
                      "(its output folder) instead of tracking the video again")
          ->check(CLI::ExistingDirectory);
  // What only tracking uses cannot be changed for a reused track.
  for (const char* name :
       {"--arm-radius", "--hfov", "--calibration", "--focal", "--camera-height", "--vertical",
        "--working-size", "--track-fps", "--readout-ms", "--threads"}) {
    from_track->excludes(sub->get_option(name));
  }
  AddMeasureFlags(sub, opt.get());
  sub->add_option("--mask-model", opt->mask.model,
                  "Optional learned trunk segmentation network (ONNX, or any format OpenCV's dnn "
                  "reads); see docs/mask-model.md")
      ->check(CLI::ExistingFile);
  sub->add_option("--mask-input-width", opt->mask.input_width, "Mask network input width (px)")
      ->capture_default_str();
  sub->add_option("--mask-input-height", opt->mask.input_height, "Mask network input height (px)")
      ->capture_default_str();
  sub->add_option("--mask-trunk-channel", opt->mask.trunk_channel,
                  "Output channel of the trunk class (a single-channel output is the trunk logit)")
      ->capture_default_str();
  sub->add_option("--mask-threshold", opt->mask.threshold, "Trunk probability threshold")
      ->capture_default_str();
  const std::function<void()> apply_options_file =
      AddOptionsFile(sub, opt.get(), "process_options.json");
  sub->callback([sub, opt, video, out, apply_options_file] {
    ApplyLogLevel(*sub);
    apply_options_file();
    const pipeline::ProcessResult r = pipeline::RunProcess(*opt, *video, *out);
    fmt::print("{}wrote {}\n", r.Table(), out->string());
  });
}

void AddStemsCommand(CLI::App& app) {
  auto opt = std::make_shared<pipeline::ProcessOptions>();
  auto video = std::make_shared<std::filesystem::path>();
  auto from = std::make_shared<std::filesystem::path>();
  auto out = std::make_shared<std::filesystem::path>();
  CLI::App* sub = app.add_subcommand(
      "stems",
      "The tree list again from a finished process run's folder (its track and cloud), with other "
      "detection or DBH options, without tracking or depth");
  sub->add_option("video", *video, "The capture video the run was made from")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--from", *from, "Output folder of a finished `stemmap process` run")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--out", *out, "Output folder")->required();
  AddMeasureFlags(sub, opt.get());
  // Without --options, the run's own options are the ones flags change.
  auto file = std::make_shared<std::filesystem::path>();
  sub->add_option("--options", *file,
                  "Every option of an earlier run (its process_options.json; default: the one in "
                  "--from); flags given here that differ from their defaults override the file's")
      ->check(CLI::ExistingFile);
  sub->callback([sub, opt, video, from, out, file] {
    ApplyLogLevel(*sub);
    // The run folder's own file may come from another version: keys it has that no option
    // has are ignored with a warning. A file given with --options must name options only.
    const std::filesystem::path saved = file->empty() ? *from / "process_options.json" : *file;
    if (std::filesystem::exists(saved)) {
      *opt = OverlayOptions(
          ReadOptionsJson<pipeline::ProcessOptions>(
              saved, file->empty() ? UnknownOptionKeys::kWarn : UnknownOptionKeys::kRefuse),
          *opt);
    }
    const pipeline::ProcessResult r = pipeline::RunStems(*opt, *video, *from, *out);
    fmt::print("{}wrote {}\n", r.Table(), out->string());
  });
}

}  // namespace stemmap::cli
