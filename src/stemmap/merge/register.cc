#include "stemmap/merge/register.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "stemmap/core/error.h"
#include "stemmap/core/units.h"

namespace stemmap::merge {

namespace {

struct Transform2d {
  double yaw_rad = 0.0;
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  Eigen::Vector2d operator*(const Eigen::Vector2d& p) const {
    const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
    return Eigen::Vector2d(c * p.x() - s * p.y(), s * p.x() + c * p.y()) + t;
  }
};

bool LikeDbh(const RegisterOptions& o, double a_cm, double b_cm) {
  return std::abs(a_cm - b_cm) <= std::max(o.dbh_slack_cm, o.dbh_share * std::max(a_cm, b_cm));
}

// The transform taking b1 → a1 and b2 → a2 as well as a rotation can (their midpoints exactly).
Transform2d FromTwoPairs(const Eigen::Vector2d& a1, const Eigen::Vector2d& a2,
                         const Eigen::Vector2d& b1, const Eigen::Vector2d& b2) {
  const Eigen::Vector2d da = a2 - a1, db = b2 - b1;
  Transform2d x;
  x.yaw_rad = std::atan2(da.y(), da.x()) - std::atan2(db.y(), db.x());
  x.t = Eigen::Vector2d::Zero();
  x.t = 0.5 * (a1 + a2) - x * (0.5 * (b1 + b2));
  return x;
}

// Greedy one-to-one matches, nearest first: each moved stem of `from` onto a stem of `to` of like
// DBH within the radius.
std::vector<std::pair<int, int>> Match(const RegisterOptions& o, const std::vector<MapStem>& to,
                                       const std::vector<MapStem>& from, const Transform2d& x) {
  struct Candidate {
    double d;
    int i, j;
  };
  std::vector<Candidate> c;
  for (size_t j = 0; j < from.size(); ++j) {
    const Eigen::Vector2d p = x * from[j].xy;
    for (size_t i = 0; i < to.size(); ++i) {
      const double d = (to[i].xy - p).norm();
      if (d <= o.match_radius_m && LikeDbh(o, to[i].dbh_cm, from[j].dbh_cm)) {
        c.push_back({d, static_cast<int>(i), static_cast<int>(j)});
      }
    }
  }
  std::ranges::sort(c, [](const Candidate& a, const Candidate& b) {
    return std::tie(a.d, a.i, a.j) < std::tie(b.d, b.i, b.j);
  });
  std::vector<char> used_to(to.size(), 0), used_from(from.size(), 0);
  std::vector<std::pair<int, int>> m;
  for (const Candidate& k : c) {
    if (used_to[k.i] || used_from[k.j]) continue;
    used_to[k.i] = used_from[k.j] = 1;
    m.emplace_back(k.i, k.j);
  }
  std::ranges::sort(m);
  return m;
}

// Weighted least squares rotation and translation of the matched stems (2-D Kabsch); no
// weights: all 1.
Transform2d Fit(const std::vector<MapStem>& to, const std::vector<MapStem>& from,
                const std::vector<std::pair<int, int>>& m, const std::vector<double>& w = {}) {
  Eigen::Vector2d ca = Eigen::Vector2d::Zero(), cb = Eigen::Vector2d::Zero();
  double sum_w = 0.0;
  for (size_t k = 0; k < m.size(); ++k) {
    const double wk = w.empty() ? 1.0 : w[k];
    ca += wk * to[m[k].first].xy;
    cb += wk * from[m[k].second].xy;
    sum_w += wk;
  }
  ca /= sum_w;
  cb /= sum_w;
  double sxx = 0.0, sxy = 0.0;  // Σ w b·a and Σ w b×a of the centred points
  for (size_t k = 0; k < m.size(); ++k) {
    const double wk = w.empty() ? 1.0 : w[k];
    const Eigen::Vector2d a = to[m[k].first].xy - ca, b = from[m[k].second].xy - cb;
    sxx += wk * b.dot(a);
    sxy += wk * (b.x() * a.y() - b.y() * a.x());
  }
  Transform2d x;
  x.yaw_rad = std::atan2(sxy, sxx);
  x.t = ca - x * cb;  // x.t is zero here, so x * cb is the rotated centroid
  return x;
}

double Rms(const std::vector<MapStem>& to, const std::vector<MapStem>& from,
           const std::vector<std::pair<int, int>>& m, const Transform2d& x) {
  double sum = 0.0;
  for (const auto& [i, j] : m) sum += (to[i].xy - x * from[j].xy).squaredNorm();
  return m.empty() ? 0.0 : std::sqrt(sum / m.size());
}

// The matched stems' fit with Cauchy weights of scale `scale_m` on their distances after the
// transform, from `x` (iteratively reweighted): a stem one run placed a decimetre off (a fit from
// one side, a cloud smeared along the line of sight) barely moves the plot, while stems that
// agree to a few centimetres all count.
Transform2d RobustFit(const std::vector<MapStem>& to, const std::vector<MapStem>& from,
                      const std::vector<std::pair<int, int>>& m, Transform2d x, double scale_m) {
  if (scale_m <= 0) return Fit(to, from, m);
  std::vector<double> w(m.size());
  for (int it = 0; it < 10; ++it) {
    for (size_t k = 0; k < m.size(); ++k) {
      const double r = (to[m[k].first].xy - x * from[m[k].second].xy).norm() / scale_m;
      w[k] = 1.0 / (1.0 + r * r);
    }
    x = Fit(to, from, m, w);
  }
  return x;
}

}  // namespace

void RegisterOptions::Check() const {
  if (!(match_radius_m > 0) || !(dbh_share >= 0) || !(dbh_slack_cm >= 0) || !(min_spacing_m > 0) ||
      !(spacing_tolerance_m > 0) || min_matches < 2 || !(robust_scale_m >= 0)) {
    throw InputError("registration options must be positive (and at least 2 matches)");
  }
}

Eigen::Vector2d Registration::Apply(const Eigen::Vector2d& from_xy) const {
  return Transform2d{yaw_deg * kDeg, translation_m} * from_xy;
}

Registration RegisterMaps(const RegisterOptions& o, const std::vector<MapStem>& to,
                          const std::vector<MapStem>& from, const RegistrationGuess* guess) {
  o.Check();
  Eigen::Vector2d from_centroid = Eigen::Vector2d::Zero();
  for (const MapStem& s : from) from_centroid += s.xy;
  if (!from.empty()) from_centroid /= static_cast<double>(from.size());
  // How far a transform puts the `from` map's centroid from where the guess does.
  const auto guess_distance = [&](const Transform2d& x) {
    if (guess == nullptr) return 0.0;
    const Transform2d g{guess->yaw_deg * kDeg, guess->translation_m};
    return (x * from_centroid - g * from_centroid).norm();
  };
  const auto near_guess = [&](const Transform2d& x) {
    if (guess == nullptr) return true;
    return std::abs(std::remainder(x.yaw_rad - guess->yaw_deg * kDeg, 2 * M_PI)) <=
               guess->max_turn_deg * kDeg &&
           guess_distance(x) <= guess->max_shift_m;
  };
  constexpr double kAlikeRmsM = 0.02;  // fits this close in rms are alike
  // Every pair of like stems is a candidate correspondence.
  std::vector<std::pair<int, int>> like;
  for (size_t i = 0; i < to.size(); ++i) {
    for (size_t j = 0; j < from.size(); ++j) {
      if (LikeDbh(o, to[i].dbh_cm, from[j].dbh_cm)) like.emplace_back(i, j);
    }
  }
  Transform2d best;
  size_t best_count = 0;
  double best_rms = kInf, best_off = kInf;
  for (size_t p = 0; p < like.size(); ++p) {
    const auto [i1, j1] = like[p];
    for (size_t q = p + 1; q < like.size(); ++q) {
      const auto [i2, j2] = like[q];
      if (i1 == i2 || j1 == j2) continue;
      const double da = (to[i1].xy - to[i2].xy).norm(), db = (from[j1].xy - from[j2].xy).norm();
      if (da < o.min_spacing_m || std::abs(da - db) > o.spacing_tolerance_m) continue;
      const Transform2d x = FromTwoPairs(to[i1].xy, to[i2].xy, from[j1].xy, from[j2].xy);
      if (!near_guess(x)) continue;
      const std::vector<std::pair<int, int>> m = Match(o, to, from, x);
      if (m.size() < best_count) continue;
      const double rms = Rms(to, from, m, x);
      // As many stems: the tighter fit, or with a guess, of fits alike (a regular grid fits as
      // well one spacing off) the one nearer the guess.
      const double off = guess_distance(x);
      const bool better = m.size() > best_count ||
                          (guess == nullptr ? rms < best_rms
                                            : rms < best_rms - kAlikeRmsM ||
                                                  (rms < best_rms + kAlikeRmsM && off < best_off));
      if (better) {
        best = x;
        best_count = m.size();
        best_rms = rms;
        best_off = off;
      }
    }
  }
  Registration r;
  if (static_cast<int>(best_count) < o.min_matches) return r;
  std::vector<std::pair<int, int>> m = Match(o, to, from, best);
  for (int round = 0; round < 5; ++round) {
    best = RobustFit(to, from, m, Fit(to, from, m), o.robust_scale_m);
    std::vector<std::pair<int, int>> again = Match(o, to, from, best);
    if (again == m) break;
    m = std::move(again);
  }
  r.ok = static_cast<int>(m.size()) >= o.min_matches;
  r.yaw_deg = std::remainder(best.yaw_rad, 2 * M_PI) / kDeg;
  r.translation_m = best.t;
  r.rms_m = Rms(to, from, m, best);
  r.matched_share =
      static_cast<double>(m.size()) / std::max<size_t>(1, std::min(to.size(), from.size()));
  r.matches = std::move(m);
  return r;
}

Registration FitPairs(const std::vector<Eigen::Vector2d>& to,
                      const std::vector<Eigen::Vector2d>& from) {
  if (to.size() != from.size() || to.size() < 2) {
    throw InputError("a transform between two frames needs at least two points seen in both");
  }
  std::vector<MapStem> a, b;
  std::vector<std::pair<int, int>> m;
  for (size_t i = 0; i < to.size(); ++i) {
    a.push_back({to[i], 0.0});
    b.push_back({from[i], 0.0});
    m.emplace_back(static_cast<int>(i), static_cast<int>(i));
  }
  const Transform2d x = Fit(a, b, m);
  Registration r;
  r.ok = true;
  r.yaw_deg = std::remainder(x.yaw_rad, 2 * M_PI) / kDeg;
  r.translation_m = x.t;
  r.rms_m = Rms(a, b, m, x);
  r.matched_share = 1.0;
  r.matches = std::move(m);
  return r;
}

}  // namespace stemmap::merge
