#pragma once

#include <vector>

namespace stemmap::eval {

// Minimum-cost assignment of rows to columns (Kuhn-Munkres, O(n^3)). `cost` is rows x cols,
// any shape. Returns, for each row, its column or -1. Pairs whose cost is >= `forbidden` are
// never returned.
std::vector<int> SolveAssignment(const std::vector<std::vector<double>>& cost, double forbidden);

}  // namespace stemmap::eval
