#include "stemmap/eval/hungarian.h"

#include <algorithm>
#include <limits>

namespace stemmap::eval {

std::vector<int> SolveAssignment(const std::vector<std::vector<double>>& cost, double forbidden) {
  const int rows = static_cast<int>(cost.size());
  const int cols = rows > 0 ? static_cast<int>(cost[0].size()) : 0;
  std::vector<int> result(rows, -1);
  if (rows == 0 || cols == 0) return result;
  // Square matrix padded with `forbidden`, potentials method (e-maxx formulation, 1-based).
  const int n = std::max(rows, cols);
  auto c = [&](int i, int j) {
    return i < rows && j < cols ? std::min(cost[i][j], forbidden) : forbidden;
  };
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> u(n + 1, 0.0), v(n + 1, 0.0);
  std::vector<int> p(n + 1, 0), way(n + 1, 0);
  for (int i = 1; i <= n; ++i) {
    p[0] = i;
    int j0 = 0;
    std::vector<double> minv(n + 1, inf);
    std::vector<char> used(n + 1, 0);
    do {
      used[j0] = 1;
      const int i0 = p[j0];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= n; ++j) {
        if (used[j]) continue;
        const double cur = c(i0 - 1, j - 1) - u[i0] - v[j];
        if (cur < minv[j]) {
          minv[j] = cur;
          way[j] = j0;
        }
        if (minv[j] < delta) {
          delta = minv[j];
          j1 = j;
        }
      }
      for (int j = 0; j <= n; ++j) {
        if (used[j]) {
          u[p[j]] += delta;
          v[j] -= delta;
        } else {
          minv[j] -= delta;
        }
      }
      j0 = j1;
    } while (p[j0] != 0);
    do {
      const int j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0);
  }
  for (int j = 1; j <= n; ++j) {
    const int i = p[j] - 1, col = j - 1;
    if (i < rows && col < cols && cost[i][col] < forbidden) result[i] = col;
  }
  return result;
}

}  // namespace stemmap::eval
