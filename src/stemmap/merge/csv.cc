#include "stemmap/merge/csv.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::merge {

namespace {

std::vector<std::string> SplitRow(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  for (std::string f; std::getline(ss, f, ',');) {
    f.erase(0, f.find_first_not_of(" \t\""));
    f.erase(f.find_last_not_of(" \t\"\r") + 1);
    fields.push_back(f);
  }
  return fields;
}

}  // namespace

int CsvTable::Column(std::initializer_list<const char*> names) const {
  for (const char* name : names) {
    const auto it = std::ranges::find(header, name);
    if (it != header.end()) return static_cast<int>(it - header.begin());
  }
  return -1;
}

double CsvTable::Number(size_t r, int c) const {
  const std::vector<std::string>& row = rows[r];
  try {
    if (c < 0 || c >= static_cast<int>(row.size())) throw std::invalid_argument("short row");
    size_t used = 0;
    const double v = std::stod(row[c], &used);
    if (used != row[c].size() || !std::isfinite(v)) throw std::invalid_argument("not a number");
    return v;
  } catch (const std::exception&) {
    throw InputError(fmt::format("{} line {}: column {} is not a number", path.string(),
                                 line_numbers[r], c < 0 ? "?" : header[c]));
  }
}

CsvTable ReadCsvTable(const std::filesystem::path& path) {
  CsvTable t;
  t.path = path;
  std::istringstream in(ReadFileToString(path));
  std::string line;
  if (!std::getline(in, line) || line.find(',') == std::string::npos) {
    throw InputError(fmt::format("{} is not a CSV table with a header row", path.string()));
  }
  t.header = SplitRow(line);
  for (int n = 2; std::getline(in, line); ++n) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    t.rows.push_back(SplitRow(line));
    t.line_numbers.push_back(n);
  }
  return t;
}

}  // namespace stemmap::merge
