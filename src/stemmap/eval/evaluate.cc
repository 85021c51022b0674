#include "stemmap/eval/evaluate.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "stemmap/core/error.h"
#include "stemmap/core/units.h"
#include "stemmap/eval/hungarian.h"

namespace stemmap::eval {

namespace {

DbhStats ComputeDbhStats(const std::vector<std::pair<double, double>>& pred_truth_cm) {
  DbhStats s;
  s.n = static_cast<int>(pred_truth_cm.size());
  if (s.n == 0) return s;
  double sum = 0, sum_abs = 0, sum_sq = 0, sum_rel = 0;
  int lt1 = 0, lt2 = 0, lt3 = 0;
  for (const auto& [p, t] : pred_truth_cm) {
    const double e = p - t;
    sum += e;
    sum_abs += std::abs(e);
    sum_sq += e * e;
    sum_rel += std::abs(e) / t;
    if (std::abs(e) < 1)
      ++lt1;
    else if (std::abs(e) < 2)
      ++lt2;
    else if (std::abs(e) < 3)
      ++lt3;
  }
  const double n = s.n;
  s.bias_cm = sum / n;
  s.mae_cm = sum_abs / n;
  s.rmse_cm = std::sqrt(sum_sq / n);
  s.sd_cm = s.n > 1 ? std::sqrt(std::max(0.0, (sum_sq - n * s.bias_cm * s.bias_cm) / (n - 1))) : 0;
  s.mare_pct = 100.0 * sum_rel / n;
  s.share_lt1_pct = 100.0 * lt1 / n;
  s.share_1to2_pct = 100.0 * lt2 / n;
  s.share_2to3_pct = 100.0 * lt3 / n;
  s.share_ge3_pct = 100.0 * (s.n - lt1 - lt2 - lt3) / n;
  return s;
}

}  // namespace

std::vector<StemRecord> RotatedAboutOrigin(const std::vector<StemRecord>& in, double yaw_deg) {
  const double c = std::cos(yaw_deg * kDeg), s = std::sin(yaw_deg * kDeg);
  std::vector<StemRecord> out = in;
  for (StemRecord& r : out) {
    const double x = c * r.x_m - s * r.y_m, y = s * r.x_m + c * r.y_m;
    r.x_m = x;
    r.y_m = y;
  }
  return out;
}

void EvaluateOptions::Check() const {
  if (!(plot_radius_m > 0)) throw InputError("plot radius must be positive");
  if (!(min_dbh_cm >= 0)) throw InputError("minimum DBH must not be negative");
  if (!(match_radius_m > 0)) throw InputError("match radius must be positive");
}

MatchStats MatchAndScore(const EvaluateOptions& o, const std::vector<StemRecord>& truth,
                         const std::vector<StemRecord>& predicted) {
  // Every prediction may take any truth tree (so that trees just outside the plot absorb their
  // own detections); only scored trees count as hits, only in-plot leftovers as false.
  // Only truth trees within the match radius of some prediction's range can take one (the yaw
  // search rotates about the origin, which keeps ranges): the assignment runs on those alone.
  std::vector<int> candidates;
  for (size_t j = 0; j < truth.size(); ++j) {
    for (const StemRecord& p : predicted) {
      if (std::abs(p.DistanceM() - truth[j].DistanceM()) <= o.match_radius_m) {
        candidates.push_back(static_cast<int>(j));
        break;
      }
    }
  }
  std::vector<std::vector<double>> cost(predicted.size(), std::vector<double>(candidates.size()));
  for (size_t i = 0; i < predicted.size(); ++i) {
    for (size_t c = 0; c < candidates.size(); ++c) {
      const StemRecord& t = truth[candidates[c]];
      cost[i][c] = std::hypot(predicted[i].x_m - t.x_m, predicted[i].y_m - t.y_m);
    }
  }
  std::vector<int> match = SolveAssignment(cost, o.match_radius_m);
  std::vector<double> match_m(predicted.size(), 0.0);
  for (size_t i = 0; i < predicted.size(); ++i) {
    if (match[i] < 0) continue;
    match_m[i] = cost[i][match[i]];
    match[i] = candidates[match[i]];
  }
  auto scored = [&](const StemRecord& t) {
    return t.DistanceM() <= o.plot_radius_m && t.dbh_cm >= o.min_dbh_cm;
  };
  MatchStats s;
  std::vector<char> truth_hit(truth.size(), 0);
  std::vector<std::pair<double, double>> dbh_pairs;
  double pos_sq = 0, pos_sum = 0;
  for (size_t i = 0; i < predicted.size(); ++i) {
    const int j = match[i];
    if (j >= 0) {
      truth_hit[j] = 1;
      if (scored(truth[j])) {
        ++s.n_matched;
        ++s.n_predicted;
        dbh_pairs.emplace_back(predicted[i].dbh_cm, truth[j].dbh_cm);
        s.pairs.push_back(
            {truth[j].id, predicted[i].id, truth[j].dbh_cm, predicted[i].dbh_cm, match_m[i]});
        pos_sq += match_m[i] * match_m[i];
        pos_sum += match_m[i];
      }
    } else if (predicted[i].DistanceM() <= o.plot_radius_m && predicted[i].dbh_cm >= o.min_dbh_cm) {
      ++s.n_predicted;
      s.false_prediction_ids.push_back(predicted[i].id);
    }
  }
  for (size_t j = 0; j < truth.size(); ++j) {
    if (!scored(truth[j])) continue;
    ++s.n_truth;
    if (!truth_hit[j]) s.missed_truth_ids.push_back(truth[j].id);
  }
  s.recall = s.n_truth > 0 ? static_cast<double>(s.n_matched) / s.n_truth : 0.0;
  s.precision = s.n_predicted > 0 ? static_cast<double>(s.n_matched) / s.n_predicted : 0.0;
  if (s.n_matched > 0) {
    s.position_rmse_m = std::sqrt(pos_sq / s.n_matched);
    s.position_mean_m = pos_sum / s.n_matched;
  }
  s.dbh = ComputeDbhStats(dbh_pairs);
  return s;
}

double BestYawDeg(const EvaluateOptions& o, const std::vector<StemRecord>& truth,
                  const std::vector<StemRecord>& predicted) {
  // Coarse search on the number of matches (ties: smaller position error), then refinement of
  // the angle in closed form from the matched pairs.
  double best_yaw = 0.0;
  int best_n = -1;
  double best_err = 1e9;
  for (double yaw = -180.0; yaw < 180.0; yaw += 0.25) {
    const MatchStats s = MatchAndScore(o, truth, RotatedAboutOrigin(predicted, yaw));
    if (s.n_matched > best_n || (s.n_matched == best_n && s.position_rmse_m < best_err)) {
      best_n = s.n_matched;
      best_err = s.position_rmse_m;
      best_yaw = yaw;
    }
  }
  for (int it = 0; it < 3; ++it) {
    const auto rotated = RotatedAboutOrigin(predicted, best_yaw);
    std::vector<std::vector<double>> cost(rotated.size(), std::vector<double>(truth.size()));
    for (size_t i = 0; i < rotated.size(); ++i) {
      for (size_t j = 0; j < truth.size(); ++j) {
        cost[i][j] = std::hypot(rotated[i].x_m - truth[j].x_m, rotated[i].y_m - truth[j].y_m);
      }
    }
    const auto match = SolveAssignment(cost, o.match_radius_m);
    double sdot = 0, scross = 0;
    for (size_t i = 0; i < rotated.size(); ++i) {
      if (match[i] < 0) continue;
      const StemRecord& p = rotated[i];
      const StemRecord& t = truth[match[i]];
      sdot += p.x_m * t.x_m + p.y_m * t.y_m;
      scross += p.x_m * t.y_m - p.y_m * t.x_m;
    }
    if (sdot <= 0) break;
    best_yaw += std::atan2(scross, sdot) / kDeg;
  }
  return best_yaw;
}

}  // namespace stemmap::eval
