#pragma once

// A 95 % interval of a figure, from simulated or resampled draws of it.
#include <algorithm>
#include <vector>

namespace stemmap::stems {

struct Interval {
  double low = 0.0, high = 0.0;
};

// The 2.5th and 97.5th percentiles of `draws` (not empty).
inline Interval Percentiles95(std::vector<double> draws) {
  std::ranges::sort(draws);
  const auto at = [&](double q) { return draws[static_cast<size_t>(q * (draws.size() - 1))]; };
  return {at(0.025), at(0.975)};
}

}  // namespace stemmap::stems
