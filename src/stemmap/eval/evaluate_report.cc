// Trajectory comparison, the whole evaluation, and its Markdown/JSON forms.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/units.h"
#include "stemmap/eval/evaluate.h"

namespace stemmap::eval {

namespace {

std::string MatchTable(const MatchStats& s) {
  const DbhStats& d = s.dbh;
  return fmt::format(
      "| recall | precision | matched | truth | predicted | position RMSE (m) |\n"
      "|---|---|---|---|---|---|\n"
      "| {:.3f} | {:.3f} | {} | {} | {} | {:.3f} |\n\n"
      "| DBH MAE (cm) | RMSE (cm) | SD (cm) | bias (cm) | MARE (%) | <1 cm | 1-2 cm | 2-3 cm | "
      ">=3 cm |\n"
      "|---|---|---|---|---|---|---|---|---|\n"
      "| {:.2f} | {:.2f} | {:.2f} | {:+.2f} | {:.2f} | {:.1f}% | {:.1f}% | {:.1f}% | {:.1f}% |\n",
      s.recall, s.precision, s.n_matched, s.n_truth, s.n_predicted, s.position_rmse_m, d.mae_cm,
      d.rmse_cm, d.sd_cm, d.bias_cm, d.mare_pct, d.share_lt1_pct, d.share_1to2_pct,
      d.share_2to3_pct, d.share_ge3_pct);
}

nlohmann::json PairsJson(const std::vector<MatchedPair>& pairs) {
  nlohmann::json j = nlohmann::json::array();
  for (const MatchedPair& p : pairs) {
    j.push_back({{"truth_id", p.truth_id},
                 {"predicted_id", p.predicted_id},
                 {"truth_dbh_cm", p.truth_dbh_cm},
                 {"predicted_dbh_cm", p.predicted_dbh_cm},
                 {"position_error_m", p.position_error_m}});
  }
  return j;
}

nlohmann::json MatchJson(const MatchStats& s) {
  const DbhStats& d = s.dbh;
  return {{"recall", s.recall},
          {"precision", s.precision},
          {"n_matched", s.n_matched},
          {"n_truth", s.n_truth},
          {"n_predicted", s.n_predicted},
          {"position_rmse_m", s.position_rmse_m},
          {"position_mean_m", s.position_mean_m},
          {"missed_truth_ids", s.missed_truth_ids},
          {"false_prediction_ids", s.false_prediction_ids},
          {"pairs", PairsJson(s.pairs)},
          {"dbh",
           {{"n", d.n},
            {"mae_cm", d.mae_cm},
            {"rmse_cm", d.rmse_cm},
            {"sd_cm", d.sd_cm},
            {"bias_cm", d.bias_cm},
            {"mare_pct", d.mare_pct},
            {"share_lt1_pct", d.share_lt1_pct},
            {"share_1to2_pct", d.share_1to2_pct},
            {"share_2to3_pct", d.share_2to3_pct},
            {"share_ge3_pct", d.share_ge3_pct}}}};
}

}  // namespace

TrajectoryStats CompareTrajectories(const std::vector<StampedPose>& truth,
                                    const std::vector<StampedPose>& estimate) {
  TrajectoryStats s;
  if (truth.empty() || estimate.empty()) return s;
  double spacing = 1.0;
  if (truth.size() > 1) spacing = (truth.back().t_s - truth.front().t_s) / (truth.size() - 1);
  const double tol = 0.5 * spacing + 1e-6;
  std::vector<std::pair<const Rigid3d*, const Rigid3d*>> pairs;  // (truth, estimate)
  size_t k = 0;
  for (const StampedPose& e : estimate) {
    while (k + 1 < truth.size() &&
           std::abs(truth[k + 1].t_s - e.t_s) <= std::abs(truth[k].t_s - e.t_s)) {
      ++k;
    }
    if (std::abs(truth[k].t_s - e.t_s) <= tol) {
      pairs.emplace_back(&truth[k].world_from_cam, &e.world_from_cam);
    }
  }
  s.n_poses = static_cast<int>(pairs.size());
  if (pairs.empty()) return s;
  double sdot = 0, scross = 0;
  for (const auto& [t, e] : pairs) {
    sdot += e->translation.x() * t->translation.x() + e->translation.y() * t->translation.y();
    scross += e->translation.x() * t->translation.y() - e->translation.y() * t->translation.x();
  }
  const double yaw = std::atan2(scross, sdot);
  s.yaw_deg = yaw / kDeg;
  const Eigen::Quaterniond rz(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  double sq = 0, num = 0, den = 0, rot_sum = 0, heading_sum = 0, up_sum = 0;
  for (const auto& [t, e] : pairs) {
    const Eigen::Vector3d p = rz * e->translation;
    sq += (p - t->translation).squaredNorm();
    num += p.dot(t->translation);
    den += t->translation.squaredNorm();
    const double ang = (rz * e->rotation).angularDistance(t->rotation) / kDeg;
    rot_sum += ang;
    const Eigen::Vector3d fe = rz * e->rotation * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d ft = t->rotation * Eigen::Vector3d::UnitZ();
    heading_sum +=
        std::remainder(std::atan2(fe.y(), fe.x()) - std::atan2(ft.y(), ft.x()), 2 * M_PI);
    const Eigen::Vector3d ue = e->rotation * -Eigen::Vector3d::UnitY();
    const Eigen::Vector3d ut = t->rotation * -Eigen::Vector3d::UnitY();
    up_sum += std::acos(std::clamp(ue.normalized().dot(ut.normalized()), -1.0, 1.0));
    s.max_rotation_error_deg = std::max(s.max_rotation_error_deg, ang);
  }
  s.ate_rmse_m = std::sqrt(sq / pairs.size());
  // Scale of the estimate relative to the truth: argmin_k Σ|p - k t|².
  s.scale_error_pct = den > 0 ? 100.0 * (num / den - 1.0) : 0.0;
  s.mean_rotation_error_deg = rot_sum / pairs.size();
  s.heading_offset_deg = heading_sum / pairs.size() / kDeg;
  s.mean_up_error_deg = up_sum / pairs.size() / kDeg;
  return s;
}

Evaluation Evaluate(const EvaluateOptions& o, const TruthPlot& truth,
                    const std::vector<StemRecord>& predicted,
                    const std::vector<StampedPose>* trajectory) {
  o.Check();
  Evaluation e;
  e.raw = MatchAndScore(o, truth.trees, predicted);
  e.yaw_deg = predicted.empty() ? 0.0 : BestYawDeg(o, truth.trees, predicted);
  e.yaw_aligned = MatchAndScore(o, truth.trees, RotatedAboutOrigin(predicted, e.yaw_deg));
  if (trajectory) {
    if (truth.poses.empty()) throw InputError("the truth file has no poses to compare with");
    e.has_trajectory = true;
    e.trajectory = CompareTrajectories(truth.poses, *trajectory);
    if (e.trajectory.n_poses == 0) {
      throw InputError("no trajectory timestamp matches a truth pose");
    }
  }
  return e;
}

std::string Evaluation::ToMarkdown() const {
  std::string md = "## Trees (plot frame as given)\n\n" + MatchTable(raw);
  md += fmt::format("\n## Trees after a yaw-only alignment ({:+.2f}°)\n\n", yaw_deg) +
        MatchTable(yaw_aligned);
  if (has_trajectory) {
    const TrajectoryStats& t = trajectory;
    md += fmt::format(
        "\n## Trajectory\n\n| poses | ATE RMSE (cm) | scale error (%) | yaw (°) | rotation error "
        "mean/max (°) | heading offset (°) | up error (°) |\n|---|---|---|---|---|---|---|\n"
        "| {} | {:.2f} | {:+.3f} | {:+.2f} | {:.3f} / {:.3f} | {:+.3f} | {:.3f} |\n",
        t.n_poses, 100.0 * t.ate_rmse_m, t.scale_error_pct, t.yaw_deg, t.mean_rotation_error_deg,
        t.max_rotation_error_deg, t.heading_offset_deg, t.mean_up_error_deg);
  }
  return md;
}

void to_json(nlohmann::json& j, const Evaluation& e) {
  j = {
      {"raw", MatchJson(e.raw)}, {"yaw_aligned", MatchJson(e.yaw_aligned)}, {"yaw_deg", e.yaw_deg}};
  if (e.has_trajectory) {
    const TrajectoryStats& t = e.trajectory;
    j["trajectory"] = {{"n_poses", t.n_poses},
                       {"ate_rmse_m", t.ate_rmse_m},
                       {"scale_error_pct", t.scale_error_pct},
                       {"yaw_deg", t.yaw_deg},
                       {"mean_rotation_error_deg", t.mean_rotation_error_deg},
                       {"max_rotation_error_deg", t.max_rotation_error_deg},
                       {"heading_offset_deg", t.heading_offset_deg},
                       {"mean_up_error_deg", t.mean_up_error_deg}};
  }
}

Evaluation RunEvaluate(const EvaluateOptions& o, const EvaluateFiles& files) {
  o.Check();
  const TruthPlot truth = ReadTruthJson(files.truth_json);
  const std::vector<StemRecord> predicted = ReadTreesCsv(files.trees_csv);
  std::vector<StampedPose> trajectory;
  if (!files.trajectory_tum.empty()) trajectory = ReadTumTrajectory(files.trajectory_tum);
  const Evaluation e =
      Evaluate(o, truth, predicted, files.trajectory_tum.empty() ? nullptr : &trajectory);
  if (!files.out_dir.empty()) {
    nlohmann::json j = e;
    j["options"] = {
        {"plot_radius_m", o.plot_radius_m},   {"min_dbh_cm", o.min_dbh_cm},
        {"match_radius_m", o.match_radius_m}, {"truth", files.truth_json.string()},
        {"trees", files.trees_csv.string()},  {"trajectory", files.trajectory_tum.string()}};
    WriteJsonAtomic(files.out_dir / "evaluation.json", j);
    WriteFileAtomic(files.out_dir / "evaluation.md", e.ToMarkdown());
  }
  return e;
}

}  // namespace stemmap::eval
