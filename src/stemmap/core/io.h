#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

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

// A temporary path beside `path` (same folder, so a rename is atomic).
std::filesystem::path TempPathFor(const std::filesystem::path& path);

// Renames `tmp` over `path`; throws InputError on failure.
void CommitTempFile(const std::filesystem::path& tmp, const std::filesystem::path& path);

}  // namespace stemmap
