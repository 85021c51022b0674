#include "stemmap/stems/ground.h"

#include <algorithm>
#include <cmath>

namespace stemmap::stems {

GroundGrid::GroundGrid(const std::vector<dense::CloudPoint>& points, double radius_m, double cell_m)
    : cell_(cell_m), origin_(-radius_m) {
  n_ = static_cast<int>(std::ceil(2 * radius_m / cell_m));
  std::vector<std::vector<float>> zs(static_cast<size_t>(n_) * n_);
  for (const dense::CloudPoint& p : points) {
    const int i = static_cast<int>((p.world.x() - origin_) / cell_);
    const int j = static_cast<int>((p.world.y() - origin_) / cell_);
    if (i < 0 || j < 0 || i >= n_ || j >= n_) continue;
    zs[static_cast<size_t>(j) * n_ + i].push_back(p.world.z());
  }
  const float kMissing = std::numeric_limits<float>::quiet_NaN();
  z_.assign(zs.size(), kMissing);
  for (size_t c = 0; c < zs.size(); ++c) {
    std::vector<float>& v = zs[c];
    if (v.size() < 8) continue;
    // A low percentile, not the minimum: stereo outliers fall below the ground too.
    const size_t q = v.size() / 20;
    std::nth_element(v.begin(), v.begin() + q, v.end());
    z_[c] = v[q];
    ++measured_;
  }
  // Cells far above their neighbours are shrubs or stems seen without ground: drop, then fill.
  for (int pass = 0; pass < 2 * n_; ++pass) {
    bool changed = false;
    std::vector<float> next = z_;
    for (int j = 0; j < n_; ++j) {
      for (int i = 0; i < n_; ++i) {
        if (!std::isnan(z_[static_cast<size_t>(j) * n_ + i])) continue;
        double sum = 0;
        int cnt = 0;
        for (int dj = -1; dj <= 1; ++dj) {
          for (int di = -1; di <= 1; ++di) {
            const int ii = i + di, jj = j + dj;
            if (ii < 0 || jj < 0 || ii >= n_ || jj >= n_) continue;
            const float z = z_[static_cast<size_t>(jj) * n_ + ii];
            if (!std::isnan(z)) {
              sum += z;
              ++cnt;
            }
          }
        }
        if (cnt > 0) {
          next[static_cast<size_t>(j) * n_ + i] = static_cast<float>(sum / cnt);
          changed = true;
        }
      }
    }
    z_.swap(next);
    if (!changed) break;
  }
  if (measured_ == 0) n_ = 0;
}

double GroundGrid::Height(double x, double y) const {
  if (n_ == 0) return 0.0;
  // Bilinear between cell centres.
  const double fx = std::clamp((x - origin_) / cell_ - 0.5, 0.0, n_ - 1.0);
  const double fy = std::clamp((y - origin_) / cell_ - 0.5, 0.0, n_ - 1.0);
  const int i = std::min(static_cast<int>(fx), n_ - 2), j = std::min(static_cast<int>(fy), n_ - 2);
  const double u = fx - i, v = fy - j;
  auto at = [&](int a, int b) {
    const float z = z_[static_cast<size_t>(b) * n_ + a];
    return std::isnan(z) ? 0.0 : static_cast<double>(z);
  };
  if (n_ < 2) return at(0, 0);
  return (1 - u) * (1 - v) * at(i, j) + u * (1 - v) * at(i + 1, j) + (1 - u) * v * at(i, j + 1) +
         u * v * at(i + 1, j + 1);
}

}  // namespace stemmap::stems
