// stemmap: one binary, one subcommand per stage. Each subcommand parses its options and calls a
// typed Run function from a library; errors reach main() as exceptions and leave as one line.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "stemmap/cli/commands.h"
#include "stemmap/core/error.h"

#ifndef STEMMAP_VERSION
#define STEMMAP_VERSION "unknown"
#endif

int main(int argc, char** argv) {
  CLI::App app{"stemmap: forest-plot tree list (stem positions and DBH) from one circular video"};
  app.set_version_flag("--version", std::string("stemmap ") + STEMMAP_VERSION);
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  stemmap::cli::AddSimulateCommand(app);
  stemmap::cli::AddCalibrateCommand(app);
  stemmap::cli::AddTrackCommand(app);
  stemmap::cli::AddProcessCommand(app);
  stemmap::cli::AddEvaluateCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // Wrong flags are bad input like any other: one line, exit code 2.
    fmt::print(stderr, "stemmap: error: {} (see --help)\n", e.what());
    return 2;
  } catch (const stemmap::InputError& e) {
    fmt::print(stderr, "stemmap: error: {}\n", e.what());
    return 2;
  } catch (const stemmap::ProcessingError& e) {
    fmt::print(stderr, "stemmap: failed: {}\n", e.what());
    return 3;
  } catch (const std::exception& e) {
    fmt::print(stderr, "stemmap: internal error: {}\n", e.what());
    return 4;
  }
  return 0;
}
