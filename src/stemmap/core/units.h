#pragma once

// Unit constants shared by every library, so no file keeps its own copy.
#include <limits>
#include <numbers>

namespace stemmap {

inline constexpr double kDeg = std::numbers::pi / 180.0;  // radians in a degree
inline constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace stemmap
