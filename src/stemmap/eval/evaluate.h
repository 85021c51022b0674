#pragma once

#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "stemmap/eval/plot_io.h"

namespace stemmap::eval {

struct EvaluateOptions {
  double plot_radius_m = 10.0;  // trees farther from the centre are not scored
  double min_dbh_cm = 7.0;      // inventory threshold
  double match_radius_m = 0.5;  // a prediction matches a tree within this horizontal distance
  void Check() const;
};

// The paper's DBH statistics over matched trees (cm; MARE in %; shares in %).
struct DbhStats {
  int n = 0;
  double mae_cm = 0, rmse_cm = 0, sd_cm = 0, bias_cm = 0, mare_pct = 0;
  double share_lt1_pct = 0, share_1to2_pct = 0, share_2to3_pct = 0, share_ge3_pct = 0;
};

// One scored truth tree and the prediction matched to it.
struct MatchedPair {
  int truth_id = 0, predicted_id = 0;
  double truth_dbh_cm = 0, predicted_dbh_cm = 0;
  double position_error_m = 0;
};

struct MatchStats {
  int n_truth = 0;      // truth trees in the plot above the threshold
  int n_predicted = 0;  // predictions that count (in the plot, or matched to a scored tree)
  int n_matched = 0;
  double recall = 0, precision = 0;
  double position_rmse_m = 0, position_mean_m = 0;
  DbhStats dbh;
  std::vector<int> missed_truth_ids;
  std::vector<int> false_prediction_ids;
  std::vector<MatchedPair> pairs;  // in the order of the predictions
};

struct TrajectoryStats {
  int n_poses = 0;        // matched by timestamp
  double ate_rmse_m = 0;  // after a yaw-only rotation about the vertical axis through the origin
  double scale_error_pct = 0;  // least-squares size of the aligned estimate over the truth, - 1
  double yaw_deg = 0;
  double max_rotation_error_deg = 0, mean_rotation_error_deg = 0;
  // The rotation error split in two: the mean signed difference of the horizontal viewing
  // directions after the alignment (the camera's heading against its place on the circle), and
  // the mean angle between the cameras' "up" directions (the vertical).
  double heading_offset_deg = 0, mean_up_error_deg = 0;
};

struct Evaluation {
  MatchStats raw;          // in the plot frame as given
  MatchStats yaw_aligned;  // after the best yaw about the origin
  double yaw_deg = 0.0;    // rotation applied to the predictions for `yaw_aligned`
  bool has_trajectory = false;
  TrajectoryStats trajectory;
  std::string ToMarkdown() const;
};

// Positions rotated by `yaw_deg` about the vertical axis through the plot centre.
std::vector<StemRecord> RotatedAboutOrigin(const std::vector<StemRecord>& in, double yaw_deg);

MatchStats MatchAndScore(const EvaluateOptions& options, const std::vector<StemRecord>& truth,
                         const std::vector<StemRecord>& predicted);
// Finds the yaw (about z through the origin) that best lays `predicted` onto `truth`.
double BestYawDeg(const EvaluateOptions& options, const std::vector<StemRecord>& truth,
                  const std::vector<StemRecord>& predicted);
TrajectoryStats CompareTrajectories(const std::vector<StampedPose>& truth,
                                    const std::vector<StampedPose>& estimate);

Evaluation Evaluate(const EvaluateOptions& options, const TruthPlot& truth,
                    const std::vector<StemRecord>& predicted,
                    const std::vector<StampedPose>* trajectory);

// `stemmap evaluate`: reads the files, prints Markdown, and writes evaluation.json/.md to
// `out_dir` when given.
struct EvaluateFiles {
  std::filesystem::path truth_json, trees_csv, trajectory_tum, out_dir;
};
Evaluation RunEvaluate(const EvaluateOptions& options, const EvaluateFiles& files);

void to_json(nlohmann::json& j, const Evaluation& e);

}  // namespace stemmap::eval
