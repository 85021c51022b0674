#pragma once

// The fused cloud on disk: a binary little-endian PLY that keeps each point's ray (the camera
// centre it was measured from) and keyframe, so detection can run again from a finished run's
// folder without depth.
#include <filesystem>
#include <vector>

#include "stemmap/dense/stereo.h"

namespace stemmap::dense {

// Writes `points` atomically: x y z (float, plot frame, m), red green blue (uchar), ox oy oz
// (float: the ray's origin), keyframe (int) and trunk (char: the learned mask's label, -1 none).
void WriteCloudPly(const std::filesystem::path& path, const std::vector<CloudPoint>& points);

// Reads a cloud WriteCloudPly wrote. Any other layout, a short or damaged file, or a value that
// is not finite is an InputError naming the file.
std::vector<CloudPoint> ReadCloudPly(const std::filesystem::path& path);

}  // namespace stemmap::dense
