#include <fmt/format.h>

#include <memory>

#include "stemmap/cli/commands.h"
#include "stemmap/track/track.h"

namespace stemmap::cli {

// Options shared by `track` and `process`: the video and what is known about the rig and camera.
void AddTrackOptions(CLI::App* sub, track::TrackOptions* opt, std::filesystem::path* video,
                     std::filesystem::path* out) {
  sub->add_option("video", *video, "Capture video (mp4/mov, H.264/HEVC)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--out", *out, "Output folder")->required();
  sub->add_option("--arm-radius", opt->arm_radius_m,
                  "Arm length: rotation axis to camera centre (m)")
      ->capture_default_str();
  auto* hfov = sub->add_option("--hfov", opt->hfov_deg,
                               "Horizontal field of view of the video (deg; default: a typical "
                               "phone main camera)")
                   ->capture_default_str();
  sub->add_option("--calibration", opt->calibration,
                  "Camera calibration (OpenCV YAML: camera_matrix, distortion_coefficients, "
                  "image_width, image_height)")
      ->check(CLI::ExistingFile)
      ->excludes(hfov);
  AddEnumOption(sub, "--focal", &opt->focal, track::kFocalModeNames,
                "Focal length in bundle adjustment: refine (the calibration's or --hfov's, "
                "refined by the closed turn), fixed (the calibration's: where the focus stays "
                "locked as it was for the calibration, best with a wide lens) or auto (refine)");
  sub->add_option("--camera-height", opt->camera_height_m,
                  "Arm height above the ground at the tripod, measured (m; default: estimated "
                  "from the ground in view)");
  AddEnumOption(sub, "--vertical", &opt->vertical_from, track::kVerticalSourceNames,
                "Where \"up\" comes from: trunks (the mean direction of the trunks' edges; trees "
                "lean, so it may be a few tenths of a degree off) or axis (the arm's rotation "
                "axis: only for a tripod levelled with its bubble before the turn)");
  sub->add_option("--working-size", opt->frontend.working_long_side_px,
                  "Long side of the tracking resolution (px)")
      ->capture_default_str();
  sub->add_option("--track-fps", opt->frontend.track_fps, "Frames tracked per second")
      ->capture_default_str();
  sub->add_option("--readout-ms", opt->frontend.readout_ms,
                  "Rolling shutter: time the camera takes to read a frame's rows, top to bottom "
                  "(ms; about 15-33 on phones, 0: a global shutter)")
      ->capture_default_str();
  sub->add_option("--threads", opt->bundle.threads,
                  "Bundle adjustment threads (above 1: faster, but not bit-reproducible)")
      ->capture_default_str();
}

void AddTrackCommand(CLI::App& app) {
  auto opt = std::make_shared<track::TrackOptions>();
  auto video = std::make_shared<std::filesystem::path>();
  auto out = std::make_shared<std::filesystem::path>();
  CLI::App* sub = app.add_subcommand(
      "track", "Camera trajectory of a capture video (trajectory.tum, sparse.ply, summary)");
  AddTrackOptions(sub, opt.get(), video.get(), out.get());
  const std::function<void()> apply_options_file =
      AddOptionsFile(sub, opt.get(), "track_options.json");
  sub->callback([sub, opt, video, out, apply_options_file] {
    ApplyLogLevel(*sub);
    apply_options_file();
    const track::TrackResult r = track::RunTrack(*opt, *video, *out);
    fmt::print("track: {}\nwrote {}\n", r.BriefReport(), out->string());
  });
}

}  // namespace stemmap::cli
