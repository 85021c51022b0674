#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

namespace stemmap::track {

struct TrackResult;

// Points as an ASCII PLY (x y z, metres), written atomically.
void WritePointsPly(const std::filesystem::path& path, const std::vector<Eigen::Vector3d>& points);

// trajectory.tum, keyframes.tum, sparse.ply, summary.json ({"track": ...}) and
// track_options.json.
void WriteTrackOutputs(const std::filesystem::path& out_dir, const TrackResult& result,
                       const nlohmann::json& options);

}  // namespace stemmap::track
