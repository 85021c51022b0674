#include "stemmap/eval/evaluate.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "stemmap/core/error.h"
#include "stemmap/core/io.h"
#include "stemmap/core/rng.h"
#include "stemmap/eval/hungarian.h"

namespace stemmap::eval {
namespace {

// A synthetic plot: 30 trees scattered to 14 m, DBH 10-50 cm.
TruthPlot MakeTruth() {
  TruthPlot t;
  Rng rng(3);
  for (int i = 0; i < 30; ++i) {
    const double r = rng.Uniform(2.0, 14.0), a = rng.Uniform(0, 6.283);
    t.trees.push_back({i + 1, r * std::cos(a), r * std::sin(a), rng.Uniform(10, 50), 0, ""});
  }
  return t;
}

TEST(Hungarian, FindsTheCheapestAssignment) {
  const std::vector<std::vector<double>> cost = {{4, 1, 3}, {2, 0, 5}, {3, 2, 2}};
  const auto m = SolveAssignment(cost, 100);
  EXPECT_EQ(m, (std::vector<int>{1, 0, 2}));
  // Forbidden pairs stay unassigned; rectangular input works.
  const auto m2 = SolveAssignment({{0.1, 9.0}, {9.0, 9.0}, {9.0, 0.2}}, 1.0);
  EXPECT_EQ(m2, (std::vector<int>{0, -1, 1}));
}

TEST(Evaluate, PerfectPredictionScoresZeroErrorAndFullRecall) {
  const TruthPlot truth = MakeTruth();
  const Evaluation e = Evaluate({}, truth, truth.trees, nullptr);
  EXPECT_GT(e.raw.n_truth, 10);
  EXPECT_DOUBLE_EQ(e.raw.recall, 1.0);
  EXPECT_DOUBLE_EQ(e.raw.precision, 1.0);
  EXPECT_DOUBLE_EQ(e.raw.dbh.mae_cm, 0.0);
  EXPECT_DOUBLE_EQ(e.raw.position_rmse_m, 0.0);
  EXPECT_NEAR(e.yaw_deg, 0.0, 1e-9);
}

TEST(Evaluate, ConstantOffsetIsAllBias) {
  const TruthPlot truth = MakeTruth();
  auto pred = truth.trees;
  for (auto& p : pred) p.dbh_cm += 2.0;
  const Evaluation e = Evaluate({}, truth, pred, nullptr);
  EXPECT_NEAR(e.raw.dbh.bias_cm, 2.0, 1e-12);
  EXPECT_NEAR(e.raw.dbh.mae_cm, 2.0, 1e-12);
  EXPECT_NEAR(e.raw.dbh.rmse_cm, 2.0, 1e-12);
  EXPECT_NEAR(e.raw.dbh.sd_cm, 0.0, 1e-6);
  EXPECT_NEAR(e.raw.dbh.share_2to3_pct, 100.0, 1e-9);
  EXPECT_NE(e.ToMarkdown().find("+2.00"), std::string::npos);
}

TEST(Evaluate, YawAlignmentRecoversARotatedPlot) {
  const TruthPlot truth = MakeTruth();
  const auto pred = RotatedAboutOrigin(truth.trees, 30.0);
  const Evaluation e = Evaluate({}, truth, pred, nullptr);
  EXPECT_LT(e.raw.recall, 0.3);
  EXPECT_NEAR(e.yaw_deg, -30.0, 1e-6);
  EXPECT_DOUBLE_EQ(e.yaw_aligned.recall, 1.0);
  EXPECT_NEAR(e.yaw_aligned.position_rmse_m, 0.0, 1e-6);
}

TEST(Evaluate, MissingAndExtraTreesLowerRecallAndPrecision) {
  const TruthPlot truth = MakeTruth();
  auto pred = truth.trees;
  // Drop the nearest in-plot tree, add a phantom at 5 m.
  auto nearest = std::min_element(pred.begin(), pred.end(), [](const auto& a, const auto& b) {
    return a.DistanceM() < b.DistanceM();
  });
  const int missing_id = nearest->id;
  pred.erase(nearest);
  pred.push_back({999, 0.0, 5.0, 30.0, 0, ""});
  const Evaluation e = Evaluate({}, truth, pred, nullptr);
  EXPECT_EQ(e.raw.n_matched, e.raw.n_truth - 1);
  EXPECT_NEAR(e.raw.recall, (e.raw.n_truth - 1.0) / e.raw.n_truth, 1e-12);
  EXPECT_LT(e.raw.precision, 1.0);
  EXPECT_EQ(e.raw.missed_truth_ids, std::vector<int>{missing_id});
  EXPECT_EQ(e.raw.false_prediction_ids, std::vector<int>{999});
  // One pair per hit, each a tree with itself.
  ASSERT_EQ(static_cast<int>(e.raw.pairs.size()), e.raw.n_matched);
  for (const MatchedPair& p : e.raw.pairs) {
    EXPECT_EQ(p.truth_id, p.predicted_id);
    EXPECT_EQ(p.truth_dbh_cm, p.predicted_dbh_cm);
    EXPECT_NE(p.truth_id, missing_id);
    EXPECT_EQ(p.position_error_m, 0.0);
  }
}

TEST(Evaluate, PlotRadiusAndThresholdSelectScoredTrees) {
  TruthPlot truth;
  truth.trees = {{1, 3, 0, 30, 0, ""}, {2, 12, 0, 30, 0, ""}, {3, 0, 4, 5, 0, ""}};
  const Evaluation e = Evaluate({}, truth, truth.trees, nullptr);
  EXPECT_EQ(e.raw.n_truth, 1);  // tree 2 is outside 10 m, tree 3 below 7 cm
  EXPECT_EQ(e.raw.n_predicted, 1);
}

TEST(Evaluate, TrajectoryAteScaleAndYaw) {
  TruthPlot truth = MakeTruth();
  std::vector<StampedPose> est;
  const double yaw = 0.2;
  const Eigen::Quaterniond rz(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  for (int i = 0; i < 100; ++i) {
    const double th = i * 0.0628;
    Rigid3d p{Eigen::Quaterniond(Eigen::AngleAxisd(th, Eigen::Vector3d::UnitZ())),
              Eigen::Vector3d(std::cos(th), std::sin(th), 1.3)};
    truth.poses.push_back({i / 30.0, p});
    // Estimate: 1% too large and rotated by -yaw.
    est.push_back(
        {i / 30.0, {rz.conjugate() * p.rotation, rz.conjugate() * (1.01 * p.translation)}});
  }
  const Evaluation e = Evaluate({}, truth, truth.trees, &est);
  ASSERT_TRUE(e.has_trajectory);
  EXPECT_EQ(e.trajectory.n_poses, 100);
  EXPECT_NEAR(e.trajectory.yaw_deg, yaw * 180 / M_PI, 1e-6);
  EXPECT_NEAR(e.trajectory.scale_error_pct, 1.0, 1e-6);
  EXPECT_NEAR(e.trajectory.ate_rmse_m, 0.01 * std::hypot(1.0, 1.3), 1e-6);
  EXPECT_NEAR(e.trajectory.max_rotation_error_deg, 0.0, 1e-6);
}

// Cameras looking outward from a circle; the estimate turned on the spot, or tilted.
TEST(Evaluate, RotationErrorSplitsIntoHeadingAndUp) {
  Eigen::Matrix3d arm_from_cam;
  arm_from_cam << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Quaterniond mount(arm_from_cam);
  TruthPlot truth = MakeTruth();
  std::vector<StampedPose> turned, tilted;
  const Eigen::Quaterniond heading(Eigen::AngleAxisd(2.0 * M_PI / 180, Eigen::Vector3d::UnitZ()));
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.5 * M_PI / 180, Eigen::Vector3d::UnitX()));
  for (int i = 0; i < 100; ++i) {
    const double th = i * 0.0628;
    const Eigen::Quaterniond rz(Eigen::AngleAxisd(th, Eigen::Vector3d::UnitZ()));
    const Rigid3d p{rz * mount, Eigen::Vector3d(std::cos(th), std::sin(th), 1.3)};
    truth.poses.push_back({i / 30.0, p});
    turned.push_back({i / 30.0, {heading * p.rotation, p.translation}});
    tilted.push_back({i / 30.0, {tilt * p.rotation, p.translation}});
  }
  const TrajectoryStats a = CompareTrajectories(truth.poses, turned);
  EXPECT_NEAR(a.heading_offset_deg, 2.0, 1e-6);
  EXPECT_NEAR(a.mean_up_error_deg, 0.0, 1e-6);
  EXPECT_NEAR(a.mean_rotation_error_deg, 2.0, 1e-6);
  const TrajectoryStats b = CompareTrajectories(truth.poses, tilted);
  EXPECT_NEAR(b.mean_up_error_deg, 0.5, 1e-6);
  EXPECT_NEAR(b.heading_offset_deg, 0.0, 0.01);
}

TEST(PlotIo, TreesCsvErrorsAreClear) {
  const auto dir = std::filesystem::temp_directory_path() / "stemmap_eval_test";
  WriteFileAtomic(dir / "bad.csv", "a,b\n1,2\n");
  EXPECT_THROW(ReadTreesCsv(dir / "bad.csv"), InputError);
  WriteFileAtomic(dir / "ok.csv", "tree_id,x_m,y_m,z_m,dbh_cm,dbh_sd_cm\n1,2.0,3.0,1.3,25.5,0.4\n");
  const auto t = ReadTreesCsv(dir / "ok.csv");
  ASSERT_EQ(t.size(), 1u);
  EXPECT_DOUBLE_EQ(t[0].dbh_cm, 25.5);
  WriteFileAtomic(dir / "nan.csv", "x_m,y_m,dbh_cm\n1,x,3\n");
  EXPECT_THROW(ReadTreesCsv(dir / "nan.csv"), InputError);
}

// A fuzzer's finding: a pose's quaternion of two numbers was read past its end.
TEST(PlotIo, TruthFilesOfTheWrongShapeAreInputErrors) {
  const auto dir = std::filesystem::temp_directory_path() / "stemmap_eval_test";
  const std::string trees = R"("trees": [{"id": 2, "x_m": -8.0, "y_m": 3.0, "dbh_cm": 12.0}])";
  for (const char* poses : {R"([{"t_s": 0.0, "t_xyz": [1, 0, 0.3], "q_xyzw": [0, 0]}])",
                            R"([{"t_s": 0.0, "t_xyz": [1], "q_xyzw": [0, 0, 0, 1]}])",
                            R"([{"t_s": 0.0}])", R"({"t_s": "now"})"}) {
    WriteFileAtomic(dir / "truth.json", "{" + trees + R"(, "poses": )" + poses + "}");
    EXPECT_THROW(ReadTruthJson(dir / "truth.json"), InputError) << poses;
  }
  WriteFileAtomic(dir / "truth.json", "{" + trees + "}");
  EXPECT_EQ(ReadTruthJson(dir / "truth.json").trees.size(), 1u);
}

}  // namespace
}  // namespace stemmap::eval
