#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "stemmap/core/io.h"
#include "stemmap/track/track.h"

namespace stemmap::cli {

// Each adds a subcommand whose callback calls the stage's Run function.
void AddSimulateCommand(CLI::App& app);
void AddEvaluateCommand(CLI::App& app);
void AddTrackCommand(CLI::App& app);
void AddCalibrateCommand(CLI::App& app);
void AddProcessCommand(CLI::App& app);
void AddStemsCommand(CLI::App& app);
void AddMergeCommand(CLI::App& app);
void AddCompareCommand(CLI::App& app);
void AddBatchCommand(CLI::App& app);

// The video, output folder and camera/rig options shared by `track` and `process`.
void AddTrackOptions(CLI::App* sub, track::TrackOptions* opt, std::filesystem::path* video,
                     std::filesystem::path* out);

// Adds --options FILE (every option of an earlier run, saved as `saved_as`) and returns what the
// subcommand's callback calls first: it lays the file's options under the flags given.
template <typename Options>
std::function<void()> AddOptionsFile(CLI::App* sub, Options* opt, const std::string& saved_as) {
  auto file = std::make_shared<std::filesystem::path>();
  sub->add_option("--options", *file,
                  "Every option of an earlier run (its " + saved_as +
                      "), to run again with them; flags given here that differ from their "
                      "defaults override the file's")
      ->check(CLI::ExistingFile);
  return [file, opt] {
    if (!file->empty()) *opt = OverlayOptions(ReadOptionsJson<Options>(*file), *opt);
  };
}

// Applies --log-level before a subcommand runs.
void ApplyLogLevel(const CLI::App& app);

}  // namespace stemmap::cli
