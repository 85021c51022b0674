#pragma once

// Tree tables as CSV: a header row and comma-separated rows (quotes around a field are dropped;
// no commas inside fields, as every tree table stemmap reads has).
#include <filesystem>
#include <initializer_list>
#include <string>
#include <vector>

namespace stemmap::merge {

struct CsvTable {
  std::filesystem::path path;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;  // blank lines left out
  std::vector<int> line_numbers;               // of each row in the file
  // The index of the first of `names` the header has; -1 when none.
  int Column(std::initializer_list<const char*> names) const;
  // Row `r`'s number in column `c`; InputError naming the file and line when it is not one.
  double Number(size_t r, int c) const;
};

// InputError naming the file when it cannot be read or has no header.
CsvTable ReadCsvTable(const std::filesystem::path& path);

}  // namespace stemmap::merge
