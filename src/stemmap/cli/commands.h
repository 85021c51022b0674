#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "stemmap/core/enum_names.h"
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

// A flag taking one of an enum's names (`names`), stored into *value; the help lists the names and
// the default (*value's name).
template <typename E, size_t N>
CLI::Option* AddEnumOption(CLI::App* sub, const std::string& flag, E* value,
                           const EnumNames<E, N>& names, const std::string& help) {
  std::vector<std::string> choices;
  for (const auto& [e, name] : names) choices.emplace_back(name);
  return sub
      ->add_option_function<std::string>(
          flag,
          [value, names, flag](const std::string& name) {
            *value = EnumFromName(names, name, flag);
          },
          help)
      ->check(CLI::IsMember(choices))
      ->default_str(std::string(EnumName(names, *value)));
}

// Applies --log-level before a subcommand runs.
void ApplyLogLevel(const CLI::App& app);

}  // namespace stemmap::cli
