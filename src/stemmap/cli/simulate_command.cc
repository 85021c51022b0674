#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <memory>
#include <opencv2/core/utils/logger.hpp>

#include "stemmap/cli/commands.h"
#include "stemmap/sim/simulate.h"

namespace stemmap::cli {

void ApplyLogLevel(const CLI::App& app) {
  const CLI::App* root = &app;
  while (root->get_parent()) root = root->get_parent();
  const spdlog::level::level_enum level =
      spdlog::level::from_str(root->get_option("--log-level")->as<std::string>());
  spdlog::set_level(level);
  // OpenCV (4.6) cannot hand its messages to our log, so it speaks only at debug level and below.
  cv::utils::logging::setLogLevel(level <= spdlog::level::debug
                                      ? cv::utils::logging::LOG_LEVEL_WARNING
                                      : cv::utils::logging::LOG_LEVEL_SILENT);
}

void AddSimulateCommand(CLI::App& app) {
  auto opt = std::make_shared<sim::SimulateOptions>();
  auto kind = std::make_shared<std::string>("managed");
  auto phone = std::make_shared<std::string>("ideal");
  CLI::App* sub = app.add_subcommand(
      "simulate", "Render a plot capture (video.mp4, truth.json, trajectory_truth.tum)");
  sub->add_option("--seed", opt->seed, "Everything follows from it")->capture_default_str();
  sub->add_option("--kind", *kind, "managed or natural")
      ->check(CLI::IsMember({"managed", "natural"}))
      ->capture_default_str();
  sub->add_option("--out", opt->out_dir, "Output folder")->required();
  sub->add_option("--width", opt->width, "Frame width (px)")->capture_default_str();
  sub->add_option("--height", opt->height, "Frame height (px)")->capture_default_str();
  sub->add_option("--fps", opt->fps, "Frames per second")->capture_default_str();
  sub->add_option("--seconds", opt->seconds, "Clip length (default: 40-50 s from the seed)");
  sub->add_option("--turns", opt->turns, "Arm turns over the clip (default: 1.05-1.15)");
  sub->add_option("--stand-tilt", opt->stand_tilt_deg,
                  "The tripod's axis from the vertical, degrees (default: 0-1.5 from the seed, a "
                  "tripod set up by eye; one levelled with its bubble: about 0.1)");
  sub->add_option("--start-deg", opt->start_deg,
                  "Bearing of the first view in the stand's frame, degrees counter-clockwise from "
                  "its x: another capture of the same stand (same seed)")
      ->capture_default_str();
  sub->add_option_function<std::vector<double>>(
         "--centre-offset",
         [opt](const std::vector<double>& v) {
           opt->centre_offset_x_m = v[0];
           opt->centre_offset_y_m = v[1];
         },
         "The tripod's offset DX,DY (m) from the stand's centre, in the stand's frame")
      ->delimiter(',')
      ->expected(2);
  sub->add_option("--arm-radius", opt->arm_radius_m, "Arm length (m)")->capture_default_str();
  sub->add_option(
      "--hfov", opt->hfov_deg,
      "Horizontal field of view through the lens (deg, default: 60-75; 100 for --phone wide)");
  sub->add_option("--phone", *phone,
                  "Camera effects of a phone: ideal (none), main (25 ms rolling shutter, residual "
                  "distortion, 0.7 % focus breathing, wind 0.5) or wide (100° with strong barrel "
                  "distortion, 30 ms readout, 0.2 % breathing, wind 0.5); the flags below "
                  "override its values")
      ->check(CLI::IsMember({"ideal", "main", "wide"}))
      ->capture_default_str();
  sub->add_option("--k1", opt->k1, "Radial distortion k1 of the simulated lens (OpenCV's)")
      ->capture_default_str();
  sub->add_option("--k2", opt->k2, "Radial distortion k2 of the simulated lens")
      ->capture_default_str();
  sub->add_option("--k3", opt->k3, "Radial distortion k3 of the simulated lens")
      ->capture_default_str();
  sub->add_option("--readout-ms", opt->phone.readout_ms,
                  "Rolling shutter: time to read the rows top to bottom (ms; 0: global shutter; "
                  "a frame's pose is its middle row's)")
      ->capture_default_str();
  sub->add_option("--breathing-pct", opt->phone.breathing_pct,
                  "Focus breathing: focal length + this % focused at 1 m, - this % at 10 m and "
                  "beyond, following the image centre's depth with a 0.3 s lag "
                  "(frames_truth.csv)")
      ->capture_default_str();
  sub->add_flag("--stabilisation", opt->phone.stabilisation,
                "Electronic stabilisation: a 1.1x crop whose principal point moves each frame to "
                "cancel the rotation's jitter (frames_truth.csv)");
  sub->add_option("--wind", opt->phone.wind,
                  "Wind strength 0-1: shrubs, saplings and crowns sway (5 cm, 4-10 cm and 30 cm "
                  "at 1); trees stand still")
      ->capture_default_str();
  sub->add_option("--bitrate", opt->bitrate_mbps, "H.264 bitrate (Mbit/s, default: phone-like)");
  sub->add_option("--layout", opt->layout_csv, "Stem map CSV with x, y, dbh (cm) columns")
      ->check(CLI::ExistingFile);
  sub->add_option("--layout-plot", opt->layout_plot,
                  "Plot id in the layout's id/plot column (default: the first)");
  sub->add_option("--stills", opt->stills, "PNG frames to write to OUT/stills")
      ->capture_default_str();
  sub->add_flag("--checkerboard", opt->checkerboard,
                "Instead of the plot, a video of a printed 9x6 checkerboard with 25-mm squares "
                "held before the same camera (the seed's and --phone's lens), for `stemmap "
                "calibrate`; its camera is in OUT/board_truth.json");
  sub->add_flag("--truth-only", opt->truth_only,
                "Write truth.json and trajectory_truth.tum without rendering the video");
  sub->callback([sub, opt, kind, phone] {
    ApplyLogLevel(*sub);
    opt->kind = sim::ParseStandKind(*kind);
    // The preset's values, then every lens or phone flag given on the command line over them.
    const sim::SimulateOptions given = *opt;
    sim::ApplyPhonePreset(sim::ParsePhonePreset(*phone), opt.get());
    const auto keep = [&](const char* flag, auto member) {
      if (sub->count(flag) > 0) (*opt).*member = given.*member;
    };
    const auto keep_phone = [&](const char* flag, auto member) {
      if (sub->count(flag) > 0) opt->phone.*member = given.phone.*member;
    };
    keep("--hfov", &sim::SimulateOptions::hfov_deg);
    keep("--k1", &sim::SimulateOptions::k1);
    keep("--k2", &sim::SimulateOptions::k2);
    keep("--k3", &sim::SimulateOptions::k3);
    keep_phone("--readout-ms", &sim::PhoneOptions::readout_ms);
    keep_phone("--breathing-pct", &sim::PhoneOptions::breathing_pct);
    keep_phone("--stabilisation", &sim::PhoneOptions::stabilisation);
    keep_phone("--wind", &sim::PhoneOptions::wind);
    const sim::SimulateSummary s = sim::RunSimulate(*opt);
    if (opt->checkerboard) {
      fmt::print(
          "simulate: checkerboard video, {} views ({:.1f} s), rendered in {:.1f} s\nwrote {}\n",
          s.frames, s.seconds, s.wall_s, opt->out_dir.string());
      return;
    }
    fmt::print("simulate: {}\nwrote {}\n", s.BriefReport(), opt->out_dir.string());
  });
}

}  // namespace stemmap::cli
