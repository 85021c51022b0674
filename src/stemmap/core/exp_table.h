#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace stemmap {

// exp(-x) for x >= 0 read linearly from a table: within 8e-6 of exp(-x) (relative) for x <= 16,
// and libm's value beyond. For smooth fields evaluated per ray (a root flare, haze), where a
// libm call per evaluation costs more than the rest of the field and the difference never shows.
class ExpNegTable {
 public:
  static constexpr double kMaxX = 16.0;
  static constexpr int kSteps = 2048;

  static const ExpNegTable& Get() {
    static const ExpNegTable table;
    return table;
  }
  double operator()(double x) const {
    if (!(x < kMaxX)) return std::exp(-x);
    const double f = std::max(x, 0.0) * (kSteps / kMaxX);
    const int i = static_cast<int>(f);
    return values_[i] + (f - i) * (values_[i + 1] - values_[i]);
  }

 private:
  ExpNegTable() {
    for (int i = 0; i <= kSteps; ++i) values_[i] = std::exp(-kMaxX * i / kSteps);
  }
  std::array<double, kSteps + 1> values_;
};

inline double ExpNeg(double x) { return ExpNegTable::Get()(x); }

}  // namespace stemmap
