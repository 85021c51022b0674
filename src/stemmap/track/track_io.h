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

// The poses, camera and summary of a finished track (its summary.json, keyframes.tum and, where
// present, trajectory.tum), without images. Throws InputError naming the file at fault.
TrackResult ReadTrackFolder(const std::filesystem::path& dir);

// A finished track read back, so later stages can run again without tracking: the keyframe poses
// (DIR/keyframes.tum, plot frame), the working camera and summary (DIR/summary.json), and the
// keyframes' images decoded from `video` at those times (BGR at the working size, and luma at the
// video's own resolution when `full_gray`). `frames` holds DIR/trajectory.tum when present.
// Throws InputError when a file is missing or unreadable, or the video does not match the track
// (another size, or no frame at a keyframe's time).
TrackResult LoadTrack(const std::filesystem::path& dir, const std::filesystem::path& video,
                      bool full_gray);

}  // namespace stemmap::track
