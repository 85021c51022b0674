#include "stemmap/core/io.h"

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <sstream>

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

nlohmann::json ReadJsonFile(const fs::path& path) {
  const std::string text = ReadFileToString(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{} is not valid JSON: {}", path.string(), e.what()));
  }
}

}  // namespace stemmap
