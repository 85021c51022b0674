#include "stemmap/core/run_folder.h"

#include <fmt/format.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <deque>
#include <fstream>
#include <mutex>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap {

namespace fs = std::filesystem;

namespace {

// Whether `dir` holds a stemmap run: its marker, or (runs made before the marker) a summary with
// the tree list or the trajectory beside it.
bool HoldsRun(const fs::path& dir) {
  std::error_code ec;
  return fs::exists(dir / kRunMarkerFile, ec) ||
         (fs::exists(dir / "summary.json", ec) &&
          (fs::exists(dir / "trees.csv", ec) || fs::exists(dir / "trajectory.tum", ec)));
}

bool IsEmptyFolder(const fs::path& dir) {
  std::error_code ec;
  return fs::is_empty(dir, ec) && !ec;
}

void RemoveAll(const fs::path& dir) {
  std::error_code ec;
  fs::remove_all(dir, ec);
  if (ec) throw InputError(fmt::format("cannot clear {}: {}", dir.string(), ec.message()));
}

// Creates `dir` and a file in it, so that a folder we cannot write to fails now, not after the
// long work.
void CheckWritable(const fs::path& dir, const fs::path& shown) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(fmt::format("cannot write to {}: {}", shown.string(), ec.message()));
  const fs::path probe = dir / ".write_probe";
  { std::ofstream(probe) << "stemmap\n"; }
  if (!fs::exists(probe, ec)) {
    throw InputError(fmt::format("cannot write to {}: permission denied", shown.string()));
  }
  fs::remove(probe, ec);
}

}  // namespace

fs::path StagingFolderFor(const fs::path& out_dir) {
  const fs::path abs = fs::absolute(out_dir).lexically_normal();
  const fs::path dir = abs.has_filename() ? abs : abs.parent_path();
  return dir.parent_path() / ("." + dir.filename().string() + ".partial");
}

StagedRunFolder::StagedRunFolder(const fs::path& out_dir, const fs::path& keep_staging)
    : out_dir_(out_dir), staging_(StagingFolderFor(out_dir)) {
  std::error_code ec;
  if (fs::exists(out_dir, ec) && !fs::is_directory(out_dir, ec)) {
    throw InputError(fmt::format("--out {} is a file, not a folder", out_dir.string()));
  }
  if (fs::is_directory(out_dir, ec) && !IsEmptyFolder(out_dir)) {
    if (!HoldsRun(out_dir)) {
      throw InputError(fmt::format(
          "--out {} holds files of something else; give a new or empty folder, or an earlier "
          "run's",
          out_dir.string()));
    }
    replaces_ = true;
    spdlog::warn("{} holds an earlier run: it is replaced when this one finishes",
                 out_dir.string());
  }
  const bool keep = !keep_staging.empty() && fs::exists(keep_staging, ec) &&
                    fs::equivalent(keep_staging, staging_, ec);
  if (!keep && fs::exists(staging_, ec)) RemoveAll(staging_);
  CheckWritable(staging_, out_dir);
  SetInterruptMessage(fmt::format("interrupted: nothing of this run was written to {}{}",
                                  out_dir.string(),
                                  replaces_ ? " (the earlier run there is unchanged)" : ""));
}

StagedRunFolder::~StagedRunFolder() {
  if (committed_) return;
  if (keep_if_unfinished_) {
    spdlog::info("what this run finished is kept in {}", staging_.string());
    return;
  }
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

void StagedRunFolder::Commit(const nlohmann::json& description) {
  WriteJsonAtomic(staging_ / kRunMarkerFile, description);
  const fs::path old = staging_.parent_path() / (staging_.filename().string() + ".old");
  std::error_code ec;
  if (fs::exists(old, ec)) RemoveAll(old);
  if (fs::exists(out_dir_, ec)) {
    fs::rename(out_dir_, old, ec);
    if (ec) {
      throw InputError(fmt::format("cannot replace {}: {} (this run is in {})", out_dir_.string(),
                                   ec.message(), staging_.string()));
    }
  }
  fs::rename(staging_, out_dir_, ec);
  if (ec) {
    throw InputError(fmt::format("cannot move the run into {}: {} (it is in {})", out_dir_.string(),
                                 ec.message(), staging_.string()));
  }
  committed_ = true;
  if (fs::exists(old, ec)) RemoveAll(old);
  if (replaces_) spdlog::info("replaced the earlier run in {}", out_dir_.string());
}

namespace {

// The handler may only read: the message is swapped in whole, and earlier ones are kept (a
// handful per run), so the pointer it reads always points at a live string.
std::atomic<const std::string*> interrupt_message{nullptr};
std::mutex interrupt_messages_mutex;
std::deque<std::string>* interrupt_messages = new std::deque<std::string>;

void OnInterrupt(int signal_number) {
  const std::string* m = interrupt_message.load();
  const char* text = m ? m->c_str() : "interrupted";
  constexpr const char kPrefix[] = "\nstemmap: ";
  [[maybe_unused]] ssize_t w = ::write(STDERR_FILENO, kPrefix, sizeof(kPrefix) - 1);
  w = ::write(STDERR_FILENO, text, std::strlen(text));
  w = ::write(STDERR_FILENO, "\n", 1);
  ::_exit(128 + signal_number);
}

}  // namespace

void SetInterruptMessage(const std::string& message) {
  const std::lock_guard lock(interrupt_messages_mutex);
  interrupt_message.store(&interrupt_messages->emplace_back(message));
}

void InstallInterruptHandler() {
  struct sigaction action {};
  action.sa_handler = OnInterrupt;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

}  // namespace stemmap
