#pragma once

#include <CLI/CLI.hpp>

namespace stemmap::cli {

// Each adds a subcommand whose callback calls the stage's Run function.
void AddSimulateCommand(CLI::App& app);
void AddEvaluateCommand(CLI::App& app);
void AddTrackCommand(CLI::App& app);
void AddCalibrateCommand(CLI::App& app);

// Applies --log-level before a subcommand runs.
void ApplyLogLevel(const CLI::App& app);

}  // namespace stemmap::cli
