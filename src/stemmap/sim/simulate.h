#pragma once

#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "stemmap/sim/phone.h"
#include "stemmap/sim/scene.h"

namespace stemmap::sim {

// `stemmap simulate`: renders the capture protocol for a generated (or given) stand.
// Zero or negative values mean "draw from the seed".
struct SimulateOptions {
  uint64_t seed = 1;
  StandKind kind = StandKind::kManaged;
  std::filesystem::path out_dir;
  int width = 1920;
  int height = 1080;
  double fps = 30.0;
  double seconds = 0.0;  // 0: 40-50 s
  double turns = 0.0;    // 0: 1.05-1.15
  double arm_radius_m = 1.0;
  // The tripod's axis from the vertical (degrees; in a direction drawn from the seed). Negative:
  // 0-1.5 drawn from the seed, a tripod set up by eye; one levelled with its bubble is within
  // about 0.1.
  double stand_tilt_deg = -1.0;
  double hfov_deg = 0.0;  // 0: 60-75°; the field through the lens, between the image's sides
  // Radial distortion of the simulated lens (OpenCV's k1, k2, k3 on normalised coordinates).
  double k1 = 0.0, k2 = 0.0, k3 = 0.0;
  PhoneOptions phone;         // rolling shutter, focus breathing, stabilisation, wind
  double bitrate_mbps = 0.0;  // 0: a phone's rate scaled to the frame size
  std::filesystem::path layout_csv;
  std::string layout_plot;  // plot id inside the layout (default: the first)
  int stills = 3;           // PNG frames written to out_dir/stills
  // Where this capture stands in the stand (the same stand for the same seed): the first view's
  // bearing, counter-clockwise from the stand's x (degrees), and the tripod's offset from the
  // stand's centre (m, stand frame). The truth is in the capture's plot frame, with the stand's
  // pose of it (`stand_from_plot`).
  double start_deg = 0.0;
  double centre_offset_x_m = 0.0, centre_offset_y_m = 0.0;
  bool truth_only = false;  // write the truth and trajectory, render nothing
  // Instead of the plot, a video of a printed 9x6 checkerboard (25-mm squares) held before the
  // same camera (the seed's lens), for `stemmap calibrate`; its truth is board_truth.json.
  bool checkerboard = false;
  void Check() const;
};

struct SimulateSummary {
  int frames = 0;
  double seconds = 0.0;
  int plot_trees = 0;  // trees within 10 m of the centre
  int all_trees = 0;
  double wall_s = 0.0;
  double render_s = 0.0, sensor_s = 0.0, encode_s = 0.0;  // parts of wall_s
  std::string BriefReport() const;
};

SimulateSummary RunSimulate(const SimulateOptions& options);

// Sets the lens (hfov_deg, k1-k3) and `phone` to the preset's values; a caller that wants some of
// them otherwise sets those after.
void ApplyPhonePreset(PhonePreset preset, SimulateOptions* options);

void to_json(nlohmann::json& j, const SimulateOptions& o);

}  // namespace stemmap::sim
