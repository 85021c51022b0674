#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "stemmap/core/error.h"

namespace stemmap {

// Writes `content` to a temporary file beside `path` and renames it over `path`, so readers never
// see a half-written file. Creates the parent folder. Throws InputError on failure.
void WriteFileAtomic(const std::filesystem::path& path, std::string_view content);

// Pretty-printed JSON, written atomically.
void WriteJsonAtomic(const std::filesystem::path& path, const nlohmann::json& json);

// Whole file as a string; throws InputError naming the file when it cannot be read.
std::string ReadFileToString(const std::filesystem::path& path);

// Parses a JSON file; throws InputError naming the file and the parse error.
nlohmann::json ReadJsonFile(const std::filesystem::path& path);

// What reading an options file does with a key that no option has.
enum class UnknownOptionKeys {
  kRefuse,  // an error: a file the user wrote, where a misspelt or misplaced key would otherwise
            // be dropped without a word and its option left at the default
  kWarn,    // a warning, the key ignored: a file an earlier run saved, perhaps another version's
};

// Throws InputError (or warns, by `policy`) naming `path` and the first key of `given`, at any
// depth, that `known` lacks, as a dotted path ("track.bundle.x").
void CheckNoUnknownKeys(const std::filesystem::path& path, const nlohmann::json& given,
                        const nlohmann::json& known, UnknownOptionKeys policy);

// Options saved by a run (`*_options.json`) read back; a missing key keeps its default. Throws
// InputError naming the file and what is wrong in it; a key that no option has is refused or
// warned of by `unknown_keys`.
template <typename Options>
Options ReadOptionsJson(const std::filesystem::path& path,
                        UnknownOptionKeys unknown_keys = UnknownOptionKeys::kRefuse) {
  const nlohmann::json j = ReadJsonFile(path);
  if (!j.is_object()) throw InputError(path.string() + ": not a JSON object of options");
  Options options;
  try {
    options = j.get<Options>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path.string() + ": " + e.what());
  } catch (const InputError& e) {  // a value its option does not take (an enum's unknown name)
    throw InputError(path.string() + ": " + e.what());
  }
  CheckNoUnknownKeys(path, j, nlohmann::json(options), unknown_keys);
  return options;
}

// Options read from a file with the command line's on top: every option the command line set to
// something other than its default (`from_command_line` against `Options{}`) replaces the file's.
template <typename Options>
Options OverlayOptions(const Options& from_file, const Options& from_command_line) {
  const nlohmann::json changes =
      nlohmann::json::diff(nlohmann::json(Options{}), nlohmann::json(from_command_line));
  return nlohmann::json(from_file).patch(changes).template get<Options>();
}

// A temporary path beside `path` (same folder, so a rename is atomic).
std::filesystem::path TempPathFor(const std::filesystem::path& path);

// Renames `tmp` over `path`; throws InputError on failure.
void CommitTempFile(const std::filesystem::path& tmp, const std::filesystem::path& path);

}  // namespace stemmap
