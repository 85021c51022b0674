#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <sstream>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/sim/scene.h"

namespace stemmap::sim {

namespace {

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      out.push_back(cur);
      cur.clear();
    } else if (c != '\r') {
      cur += c;
    }
  }
  out.push_back(cur);
  for (std::string& s : out) {
    s.erase(0, s.find_first_not_of(" \t"));
    s.erase(s.find_last_not_of(" \t") + 1);
  }
  return out;
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

}  // namespace

std::vector<LayoutStem> ReadLayoutCsv(const std::filesystem::path& path,
                                      const std::string& plot_id) {
  std::istringstream in(ReadFileToString(path));
  std::string line;
  if (!std::getline(in, line)) throw InputError(fmt::format("layout {} is empty", path.string()));
  const std::vector<std::string> header = SplitCsvLine(line);
  int ix = -1, iy = -1, idbh = -1, iplot = -1;
  for (int i = 0; i < static_cast<int>(header.size()); ++i) {
    const std::string h = Lower(header[i]);
    if (h == "x" || h == "x_m") ix = i;
    if (h == "y" || h == "y_m") iy = i;
    if (h == "dbh" || h == "dbh_cm") idbh = i;
    if (h == "id" || h == "plot" || h == "plot_id") iplot = i;
  }
  if (ix < 0 || iy < 0 || idbh < 0) {
    throw InputError(fmt::format("layout {} needs columns x, y and dbh (cm)", path.string()));
  }
  std::string chosen = plot_id;
  std::vector<LayoutStem> stems;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> f = SplitCsvLine(line);
    const int need = std::max({ix, iy, idbh, iplot}) + 1;
    if (static_cast<int>(f.size()) < need) {
      throw InputError(fmt::format("{}:{}: expected {} fields", path.string(), line_no, need));
    }
    if (iplot >= 0) {
      if (chosen.empty()) chosen = f[iplot];
      if (f[iplot] != chosen) continue;
    }
    try {
      stems.push_back({std::stod(f[ix]), std::stod(f[iy]), std::stod(f[idbh])});
    } catch (const std::exception&) {
      throw InputError(fmt::format("{}:{}: x, y or dbh is not a number", path.string(), line_no));
    }
  }
  if (stems.empty()) {
    throw InputError(fmt::format("layout {} has no stems{}", path.string(),
                                 plot_id.empty() ? "" : " for plot " + plot_id));
  }
  return stems;
}

}  // namespace stemmap::sim
