#include "stemmap/core/pose.h"

#include <fmt/format.h>

#include <sstream>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"

namespace stemmap {

void WriteTumTrajectory(const std::filesystem::path& path, const std::vector<StampedPose>& poses) {
  std::string text = "# t tx ty tz qx qy qz qw (world_from_camera, OpenCV camera axes)\n";
  for (const StampedPose& p : poses) {
    const Eigen::Quaterniond q = p.world_from_cam.rotation.normalized();
    const Eigen::Vector3d& t = p.world_from_cam.translation;
    text += fmt::format("{:.6f} {:.6f} {:.6f} {:.6f} {:.9f} {:.9f} {:.9f} {:.9f}\n", p.t_s, t.x(),
                        t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
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
    poses.push_back({v[0], {q.normalized(), Eigen::Vector3d(v[1], v[2], v[3])}});
  }
  return poses;
}

}  // namespace stemmap
