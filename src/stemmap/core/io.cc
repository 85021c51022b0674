#include "stemmap/core/io.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

#include "stemmap/core/error.h"

namespace stemmap {

namespace fs = std::filesystem;

fs::path TempPathFor(const fs::path& path) {
  static std::atomic<int> counter{0};
  return path.parent_path() /
         fmt::format(".{}.tmp{}-{}", path.filename().string(), ::getpid(), counter++);
}

void CommitTempFile(const fs::path& tmp, const fs::path& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError(fmt::format("cannot write {}: {}", path.string(), ec.message()));
  }
}

void WriteFileAtomic(const fs::path& path, std::string_view content) {
  if (path.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
    if (ec) {
      throw InputError(
          fmt::format("cannot create folder {}: {}", path.parent_path().string(), ec.message()));
    }
  }
  const fs::path tmp = TempPathFor(path);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw InputError(fmt::format("cannot write {}", path.string()));
    }
  }
  CommitTempFile(tmp, path);
}

void WriteJsonAtomic(const fs::path& path, const nlohmann::json& json) {
  WriteFileAtomic(path, json.dump(2) + "\n");
}

std::string ReadFileToString(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("cannot read {}", path.string()));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

namespace {

// The first number in `j` (walked without recursion: a file may nest deeply) written with a
// fraction or exponent and beyond what an int holds, or nullptr. nlohmann's get<int>() of such a
// number is undefined behaviour (a fuzzer's finding: an id of 1e50), and no field of ours is
// that large.
const nlohmann::json* FindHugeNumber(const nlohmann::json& j) {
  constexpr double kLimit = 2147483647.0;
  std::vector<const nlohmann::json*> todo = {&j};
  while (!todo.empty()) {
    const nlohmann::json* v = todo.back();
    todo.pop_back();
    if (v->is_number_float() && !(std::abs(v->get<double>()) <= kLimit)) return v;
    if (v->is_structured()) {
      for (const nlohmann::json& child : *v) todo.push_back(&child);
    }
  }
  return nullptr;
}

// Adds to `out` the dotted paths of the keys of `given` that `known` lacks, below `prefix`.
void AddUnknownKeys(const nlohmann::json& given, const nlohmann::json& known,
                    const std::string& prefix, std::vector<std::string>* out) {
  for (const auto& [key, value] : given.items()) {
    const std::string path = prefix.empty() ? key : prefix + "." + key;
    const auto it = known.find(key);
    if (it == known.end()) {
      out->push_back(path);
    } else if (value.is_object() && it->is_object()) {
      AddUnknownKeys(value, *it, path, out);
    }
  }
}

}  // namespace

void CheckNoUnknownKeys(const fs::path& path, const nlohmann::json& given,
                        const nlohmann::json& known, UnknownOptionKeys policy) {
  std::vector<std::string> unknown;
  if (given.is_object() && known.is_object()) AddUnknownKeys(given, known, "", &unknown);
  if (unknown.empty()) return;
  const std::string what = fmt::format(
      "{}: no option is called '{}'{}", path.string(), unknown.front(),
      unknown.size() > 1 ? fmt::format(" ({} more unknown keys)", unknown.size() - 1) : "");
  if (policy == UnknownOptionKeys::kRefuse) throw InputError(what);
  spdlog::warn("{}; ignored", what);
}

nlohmann::json ReadJsonFile(const fs::path& path) {
  const std::string text = ReadFileToString(path);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{} is not valid JSON: {}", path.string(), e.what()));
  }
  if (const nlohmann::json* huge = FindHugeNumber(j)) {
    throw InputError(
        fmt::format("{} holds a number out of range: {}", path.string(), huge->dump()));
  }
  return j;
}

}  // namespace stemmap
