#include <fmt/format.h>

#include <memory>

#include "stemmap/calib/calibrate.h"
#include "stemmap/cli/commands.h"

namespace stemmap::cli {

void AddCalibrateCommand(CLI::App& app) {
  auto opt = std::make_shared<calib::CalibrateOptions>();
  auto video = std::make_shared<std::filesystem::path>();
  auto out = std::make_shared<std::filesystem::path>("calibration.yaml");
  auto board = std::make_shared<std::string>("9x6");
  auto square_mm = std::make_shared<double>(25.0);
  auto lens = std::make_shared<std::string>("main");
  CLI::App* sub = app.add_subcommand(
      "calibrate", "Camera intrinsics from a video of a printed checkerboard (OpenCV YAML)");
  sub->add_option("video", *video, "Checkerboard video, same phone and video mode as the plots")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--board", *board, "Inner corners, columns x rows")->capture_default_str();
  sub->add_option("--square", *square_mm, "Square size (mm)")->capture_default_str();
  sub->add_option("--max-views", opt->max_views, "Board views used")->capture_default_str();
  sub->add_option("--lens", *lens,
                  "main (distortion k1, k2: a phone's main camera) or wide (k1, k2, k3: the 0.5x "
                  "ultra-wide camera, about 100°, whose distortion grows fast toward the corners)")
      ->check(CLI::IsMember({"main", "wide"}))
      ->capture_default_str();
  sub->add_option("--out", *out, "Calibration file to write")->capture_default_str();
  sub->callback([sub, opt, video, out, board, square_mm, lens] {
    ApplyLogLevel(*sub);
    if (std::sscanf(board->c_str(), "%dx%d", &opt->inner_cols, &opt->inner_rows) != 2) {
      throw CLI::ValidationError("--board", "expected COLSxROWS, e.g. 9x6");
    }
    opt->square_m = *square_mm / 1000.0;
    opt->lens = calib::ParseLensKind(*lens);
    const calib::CalibrateSummary s = calib::RunCalibrate(*opt, *video, *out);
    fmt::print("calibrate: {}\nwrote {}\n", s.BriefReport(), out->string());
  });
}

}  // namespace stemmap::cli
