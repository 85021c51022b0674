#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace stemmap {

// A run's output folder, filled in a staging folder beside it and moved into place whole, so a
// folder never mixes two runs: an interrupted or failed run leaves the earlier one untouched.
//
// The constructor checks, before any work, that the folder can be written: `out_dir` must be
// missing, empty, or hold an earlier stemmap run (which is replaced on Commit(), as the log
// says); a file, a folder of other files or an unwritable place is an InputError naming it.
// The staging folder is `.NAME.partial` beside `out_dir`; a leftover one from an interrupted run
// is cleared, unless `keep_staging` names it (a run going on from what that one finished).
class StagedRunFolder {
 public:
  explicit StagedRunFolder(const std::filesystem::path& out_dir,
                           const std::filesystem::path& keep_staging = {});
  // An unfinished run's staging folder is removed, unless KeepIfUnfinished() was called.
  ~StagedRunFolder();
  StagedRunFolder(const StagedRunFolder&) = delete;
  StagedRunFolder& operator=(const StagedRunFolder&) = delete;

  // Where the run writes its files until Commit().
  const std::filesystem::path& staging() const { return staging_; }
  const std::filesystem::path& out_dir() const { return out_dir_; }
  // Writes the run's marker (kRunMarkerFile: `description`, what made it) and moves the staged
  // run into place, replacing an earlier run there. Throws InputError.
  void Commit(const nlohmann::json& description);
  // From now on an unfinished run leaves its staging folder (what it finished can be gone on
  // from), saying so in the log.
  void KeepIfUnfinished() { keep_if_unfinished_ = true; }

 private:
  std::filesystem::path out_dir_, staging_;
  bool replaces_ = false;
  bool committed_ = false;
  bool keep_if_unfinished_ = false;
};

// The file that marks a folder as a finished stemmap run (what wrote it, and when).
inline constexpr const char* kRunMarkerFile = "stemmap_run.json";

// The staging folder StagedRunFolder uses for `out_dir`.
std::filesystem::path StagingFolderFor(const std::filesystem::path& out_dir);

// Ctrl-C and SIGTERM end the program at once with one line on stderr: the message last set here
// (what was kept and how to go on), and exit code 130 (SIGINT) or 143 (SIGTERM).
void InstallInterruptHandler();
void SetInterruptMessage(const std::string& message);

}  // namespace stemmap
