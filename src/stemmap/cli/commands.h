#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>

#include "stemmap/track/track.h"

namespace stemmap::cli {

// Each adds a subcommand whose callback calls the stage's Run function.
void AddSimulateCommand(CLI::App& app);
void AddEvaluateCommand(CLI::App& app);
void AddTrackCommand(CLI::App& app);
void AddCalibrateCommand(CLI::App& app);
void AddProcessCommand(CLI::App& app);

// The video, output folder and camera/rig options shared by `track` and `process`.
void AddTrackOptions(CLI::App* sub, track::TrackOptions* opt, std::filesystem::path* video,
                     std::filesystem::path* out);

// Applies --log-level before a subcommand runs.
void ApplyLogLevel(const CLI::App& app);

}  // namespace stemmap::cli
