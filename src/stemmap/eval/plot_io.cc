#include "stemmap/eval/plot_io.h"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap::eval {

double StemRecord::DistanceM() const { return std::hypot(x_m, y_m); }

TruthPlot ReadTruthJson(const std::filesystem::path& path) {
  const nlohmann::json j = ReadJsonFile(path);
  TruthPlot truth;
  try {
    for (const auto& t : j.at("trees")) {
      truth.trees.push_back({t.at("id").get<int>(), t.at("x_m").get<double>(),
                             t.at("y_m").get<double>(), t.at("dbh_cm").get<double>(), 0.0, ""});
    }
    truth.arm_radius_m = j.value("arm_radius_m", 0.0);
    if (j.contains("poses")) {
      for (const auto& p : j.at("poses")) {
        const auto& t = p.at("t_xyz");
        const auto& q = p.at("q_xyzw");
        Rigid3d pose;
        pose.translation = {t.at(0).get<double>(), t.at(1).get<double>(), t.at(2).get<double>()};
        pose.rotation = Eigen::Quaterniond(q.at(3).get<double>(), q.at(0).get<double>(),
                                           q.at(1).get<double>(), q.at(2).get<double>())
                            .normalized();
        truth.poses.push_back({p.at("t_s").get<double>(), pose});
      }
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{} is not a stemmap truth file: {}", path.string(), e.what()));
  }
  return truth;
}

std::vector<StemRecord> ReadTreesCsv(const std::filesystem::path& path) {
  std::istringstream in(ReadFileToString(path));
  std::string line;
  if (!std::getline(in, line)) throw InputError(fmt::format("{} is empty", path.string()));
  auto split = [](const std::string& s) {
    std::vector<std::string> f;
    std::stringstream ss(s);
    std::string x;
    while (std::getline(ss, x, ',')) {
      x.erase(0, x.find_first_not_of(" \t\""));
      x.erase(x.find_last_not_of(" \t\"\r") + 1);
      f.push_back(x);
    }
    return f;
  };
  const auto header = split(line);
  int ix = -1, iy = -1, idbh = -1, iid = -1, isd = -1, iflags = -1;
  for (int i = 0; i < static_cast<int>(header.size()); ++i) {
    if (header[i] == "x_m") ix = i;
    if (header[i] == "y_m") iy = i;
    if (header[i] == "dbh_cm") idbh = i;
    if (header[i] == "tree_id") iid = i;
    if (header[i] == "dbh_sd_cm") isd = i;
    if (header[i] == "flags") iflags = i;
  }
  if (ix < 0 || iy < 0 || idbh < 0) {
    throw InputError(fmt::format("{} needs columns x_m, y_m and dbh_cm", path.string()));
  }
  std::vector<StemRecord> trees;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
    const auto f = split(line);
    auto field = [&](int i) -> const std::string& {
      static const std::string kEmpty;
      return i >= 0 && i < static_cast<int>(f.size()) ? f[i] : kEmpty;
    };
    StemRecord r;
    try {
      r.x_m = std::stod(field(ix));
      r.y_m = std::stod(field(iy));
      r.dbh_cm = std::stod(field(idbh));
      r.id = iid >= 0 ? std::stoi(field(iid)) : static_cast<int>(trees.size()) + 1;
      r.dbh_sd_cm = isd >= 0 && !field(isd).empty() ? std::stod(field(isd)) : 0.0;
    } catch (const std::exception&) {
      throw InputError(
          fmt::format("{}:{}: a number is missing or malformed", path.string(), line_no));
    }
    r.flags = field(iflags);
    if (!std::isfinite(r.x_m) || !std::isfinite(r.y_m) || !std::isfinite(r.dbh_cm)) {
      throw InputError(fmt::format("{}:{}: non-finite value", path.string(), line_no));
    }
    trees.push_back(r);
  }
  return trees;
}

}  // namespace stemmap::eval
