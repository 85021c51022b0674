// stemmap: one binary, one subcommand per stage. Each subcommand parses its options and calls a
// typed Run function from a library; errors reach main() as exceptions and leave as one line.
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <string>

#include "stemmap/cli/commands.h"
#include "stemmap/core/error.h"
#include "stemmap/core/run_folder.h"

#ifndef STEMMAP_VERSION
#define STEMMAP_VERSION "unknown"
#endif

namespace {

// Messages leave on one line, whatever a library put in them.
std::string OneLine(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  stemmap::InstallInterruptHandler();
  // The log goes to stderr with the errors; stdout carries only the results (the tree table).
  spdlog::set_default_logger(spdlog::stderr_color_mt("stemmap"));
  // OpenCV's messages would interleave with ours (ApplyLogLevel lets them through at debug);
  // its errors arrive as exceptions.
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  CLI::App app{"stemmap: forest-plot tree list (stem positions and DBH) from one circular video"};
  app.set_version_flag("--version", std::string("stemmap ") + STEMMAP_VERSION);
  app.require_subcommand(1);
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error or off")
      ->default_val("info")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  stemmap::cli::AddSimulateCommand(app);
  stemmap::cli::AddCalibrateCommand(app);
  stemmap::cli::AddTrackCommand(app);
  stemmap::cli::AddProcessCommand(app);
  stemmap::cli::AddStemsCommand(app);
  stemmap::cli::AddMergeCommand(app);
  stemmap::cli::AddCompareCommand(app);
  stemmap::cli::AddBatchCommand(app);
  stemmap::cli::AddEvaluateCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // Wrong flags are bad input like any other: one line, exit code 2.
    fmt::print(stderr, "stemmap: error: {} (see --help)\n", OneLine(e.what()));
    return 2;
  } catch (const stemmap::InputError& e) {
    fmt::print(stderr, "stemmap: error: {}\n", OneLine(e.what()));
    return 2;
  } catch (const stemmap::ProcessingError& e) {
    fmt::print(stderr, "stemmap: failed: {}\n", OneLine(e.what()));
    return 3;
  } catch (const cv::Exception& e) {
    fmt::print(stderr, "stemmap: internal error: OpenCV {}: {}\n", e.func, OneLine(e.err));
    return 4;
  } catch (const std::exception& e) {
    fmt::print(stderr, "stemmap: internal error: {}\n", OneLine(e.what()));
    return 4;
  }
  return 0;
}
