#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace stemmap {

// Cheap stand-ins for libm functions on the renderer's per-ray paths, each within a stated error.

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

// atan2(y, x) within 1e-7 rad: a polynomial in (min/max)² of |x| and |y|, the octant restored by
// symmetry. The bark is looked up by azimuth several times per ray; libm's atan2, exact to the
// last bit, costs more than the lookup itself. atan2(0, 0) is 0; -0 is not told from +0.
inline double FastAtan2(double y, double x) {
  const double ax = std::abs(x), ay = std::abs(y);
  // Written out so that a NaN in either lands in hi or lo, and comes out.
  const double hi = ax > ay ? ax : ay, lo = ax > ay ? ay : ax;
  if (!(hi > 0.0)) return hi == 0.0 ? 0.0 : std::atan2(y, x);  // zero, or NaN passed through
  const double a = lo / hi, t = a * a;
  // Least-squares fit of atan(a) / a over t = a² in [0, 1], weighted to its largest errors.
  double r = -0.004778615182264827;
  r = r * t + 0.02455070087805064;
  r = r * t - 0.05989591059003259;
  r = r * t + 0.09942160985166412;
  r = r * t - 0.1402921135352839;
  r = r * t + 0.19971340612896582;
  r = r * t - 0.3333209137037431;
  r = (r * t + 0.9999999111973452) * a;
  if (ay > ax) r = 1.5707963267948966 - r;
  if (x < 0.0) r = 3.141592653589793 - r;
  return y < 0.0 ? -r : r;
}

}  // namespace stemmap
