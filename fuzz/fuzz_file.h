#pragma once

// What every fuzz target shares: the input written to a file (stemmap's parsers read files), and
// the rule that a parser may refuse an input only with an InputError. Any other exception, a
// crash or a sanitizer report is a finding.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>

#include "stemmap/core/error.h"

namespace stemmap::fuzz {

// A file in a folder of this process's own, holding `data`.
// The folder is removed when the process ends normally (libFuzzer's exit runs static
// destructors); a crash leaves it with the input that caused it.
class InputFolder {
 public:
  InputFolder()
      : dir_(std::filesystem::temp_directory_path() /
             ("stemmap_fuzz_" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(dir_);
  }
  ~InputFolder() {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
};

inline std::filesystem::path WriteInput(std::string_view name, std::string_view data) {
  static const InputFolder folder;
  const std::filesystem::path path = folder.dir() / name;
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(data.data(), data.size());
  return path;
}

inline std::string_view AsText(const uint8_t* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// Runs `parse`; an InputError is a refusal, the expected answer to most inputs.
template <typename Parse>
int Parse(Parse&& parse) {
  try {
    parse();
  } catch (const InputError&) {
  }
  return 0;
}

}  // namespace stemmap::fuzz
