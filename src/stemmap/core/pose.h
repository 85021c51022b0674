#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <filesystem>
#include <vector>

namespace stemmap {

// A rigid transform b_from_a: p_b = rotation * p_a + translation. Names say which frames it maps,
// e.g. `world_from_cam`.
struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return rotation * p + translation; }
  Rigid3d operator*(const Rigid3d& other) const {
    return {rotation * other.rotation, rotation * other.translation + translation};
  }
  Rigid3d Inverse() const {
    const Eigen::Quaterniond inv = rotation.conjugate();
    return {inv, -(inv * translation)};
  }
};

// One pose with its timestamp, as in a TUM trajectory line.
struct StampedPose {
  double t_s = 0.0;
  Rigid3d world_from_cam;
};

// TUM format: `t tx ty tz qx qy qz qw` per line, world_from_camera. Written atomically.
void WriteTumTrajectory(const std::filesystem::path& path, const std::vector<StampedPose>& poses);
// Throws InputError naming the file and line on malformed input. Lines starting with '#' are
// skipped.
std::vector<StampedPose> ReadTumTrajectory(const std::filesystem::path& path);

}  // namespace stemmap
