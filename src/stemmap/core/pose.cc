#include "stemmap/core/pose.h"

#include <fmt/format.h>

#include <cmath>
#include <sstream>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap {

void WriteTumTrajectory(const std::filesystem::path& path, const std::vector<StampedPose>& poses) {
  std::string text = "# t tx ty tz qx qy qz qw (world_from_camera, OpenCV camera axes)\n";
  // Shortest round-trip digits: a stage that reads the file back sees the very same poses.
  for (const StampedPose& p : poses) {
    Eigen::Quaterniond q = p.world_from_cam.rotation;
    if (std::abs(q.norm() - 1.0) > 1e-9) q.normalize();
    const Eigen::Vector3d& t = p.world_from_cam.translation;
    text += fmt::format("{:.6f} {} {} {} {} {} {} {}\n", p.t_s, t.x(), t.y(), t.z(), q.x(), q.y(),
                        q.z(), q.w());
  }
  WriteFileAtomic(path, text);
}

std::vector<StampedPose> ReadTumTrajectory(const std::filesystem::path& path) {
  std::istringstream in(ReadFileToString(path));
  std::vector<StampedPose> poses;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    double v[8];
    for (double& x : v) {
      if (!(ls >> x)) {
        throw InputError(fmt::format("{}:{}: expected 8 numbers (t tx ty tz qx qy qz qw)",
                                     path.string(), line_no));
      }
    }
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (q.norm() < 1e-9) {
      throw InputError(fmt::format("{}:{}: zero quaternion", path.string(), line_no));
    }
    if (std::abs(q.norm() - 1.0) > 1e-9) q.normalize();  // a unit one stays bit for bit
    poses.push_back({v[0], {q, Eigen::Vector3d(v[1], v[2], v[3])}});
  }
  return poses;
}

}  // namespace stemmap
