#include <gtest/gtest.h>

#include <map>
#include <sstream>

#include "vims_eval/eval_options.h"
#include "vims_eval/report.h"

using vims::StampedPose;
using namespace vims::eval;

namespace {

std::map<std::string, std::string> parseSummary(const std::string& line, const std::string& tag) {
  std::istringstream is(line);
  std::string word;
  is >> word;
  EXPECT_EQ(word, tag);
  std::map<std::string, std::string> kv;
  while (is >> word) {
    const auto eq = word.find('=');
    EXPECT_NE(eq, std::string::npos) << word;
    kv[word.substr(0, eq)] = word.substr(eq + 1);
  }
  return kv;
}

std::vector<StampedPose> line(double scale) {
  std::vector<StampedPose> poses(101);
  for (int i = 0; i <= 100; ++i) {
    poses[i].t = i;
    poses[i].p = Eigen::Vector3d(scale * i, 0.5 * scale * std::sin(0.1 * i), 0.0);
  }
  return poses;
}

}  // namespace

TEST(Report, TrajectorySummaryLineIsParseable) {
  const TrajectoryEvaluation ev = evaluateTrajectory(line(1.0), line(1.05), TrajectoryEvalOptions{}, "my vio");
  const std::string summary = trajectorySummaryLine(ev);
  const auto kv = parseSummary(summary, "VIMS_EVAL");
  EXPECT_EQ(kv.at("label"), "my_vio");
  EXPECT_EQ(kv.at("align"), "se3");
  EXPECT_EQ(kv.at("poses"), "101");
  for (const char* key : {"dist_m", "duration_s", "ate_se3_m", "ate_se3_pct", "ate_sim3_m", "ate_sim3_pct", "scale",
                          "ate_posyaw_m", "ate_none_m", "rot_rmse_deg", "rpe10_trans_m", "rpe10_trans_pct",
                          "rpe10_rot_deg", "rpe10_pairs", "tilt_rmse_deg", "height_rmse_m"})
    EXPECT_TRUE(kv.count(key)) << key << " missing in " << summary;
  EXPECT_NEAR(std::stod(kv.at("scale")), 1.0 / 1.05, 1e-5);
  EXPECT_NEAR(std::stod(kv.at("ate_sim3_m")), 0.0, 1e-4);
  EXPECT_GT(std::stod(kv.at("ate_se3_m")), 0.5);

  std::ostringstream table;
  printTrajectoryReport(table, ev);
  EXPECT_NE(table.str().find("sim3"), std::string::npos);

  const YAML::Node node = YAML::Load(emitYaml(trajectoryToYaml(ev)));
  EXPECT_EQ(node["associated_poses"].as<int>(), 101);
  EXPECT_NEAR(node["alignments"]["sim3"]["scale"].as<double>(), 1.0 / 1.05, 1e-9);
  EXPECT_EQ(node["alignments"]["se3"]["R_w_v"].size(), 9u);
  EXPECT_EQ(node["summary"].as<std::string>(), summary);
}

TEST(Report, ShortPathHasNoRpeAndSaysNan) {
  std::vector<StampedPose> gt = line(0.05);  // 5 m: no 10 m pair
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, gt, TrajectoryEvalOptions{}, "short");
  const auto kv = parseSummary(trajectorySummaryLine(ev), "VIMS_EVAL");
  EXPECT_EQ(kv.at("rpe10_trans_m"), "nan");
  EXPECT_EQ(kv.at("rpe10_pairs"), "0");
  const YAML::Node node = YAML::Load(emitYaml(trajectoryToYaml(ev)));
  EXPECT_TRUE(node["alignments"]["se3"]["rpe"]["trans_m"]["rmse"].IsNull());
}

TEST(Report, LoopSummaryLine) {
  LoopEvaluation ev;
  ev.score.verifications = 12;
  ev.score.accepted = 5;
  ev.score.correct = 4;
  ev.score.wrong = 1;
  ev.revisits.events = 3;
  ev.revisits.closed = 2;
  const auto kv = parseSummary(loopSummaryLine(ev), "VIMS_EVAL_LOOPS");
  EXPECT_EQ(kv.at("verifications"), "12");
  EXPECT_EQ(kv.at("accepted"), "5");
  EXPECT_EQ(kv.at("correct"), "4");
  EXPECT_EQ(kv.at("wrong"), "1");
  EXPECT_EQ(kv.at("revisit_events"), "3");
  EXPECT_EQ(kv.at("closed"), "2");
  EXPECT_EQ(kv.at("closed_pct"), "66.67");
  EXPECT_EQ(kv.at("precision"), "0.8000");
  EXPECT_EQ(kv.at("loop_trans_err_median_m"), "nan");  // no scored loops in ev.score.loops
}

TEST(Report, LoopAccuracyOfTheAcceptedLoopsWithGroundTruth) {
  LoopScore score;
  auto add = [&](bool accepted, bool has_gt, double trans, double rot) {
    ScoredLoop l;
    l.record.accepted = accepted;
    l.has_gt = has_gt;
    l.trans_error_m = trans;
    l.rot_error_deg = rot;
    score.loops.push_back(l);
  };
  for (int i = 1; i <= 11; ++i) add(true, true, 0.001 * i, 0.01 * i);  // 1..11 mm
  add(false, true, 5.0, 50.0);                                         // rejected: not an edge
  add(true, false, 5.0, 50.0);                                         // no ground truth: not scored
  const LoopAccuracy a = loopAccuracy(score);
  EXPECT_EQ(a.loops, 11u);
  EXPECT_NEAR(a.trans_error_median_m, 0.006, 1e-12);
  EXPECT_NEAR(a.trans_error_p90_m, 0.010, 1e-12);
  EXPECT_NEAR(a.rot_error_median_deg, 0.06, 1e-12);
  LoopEvaluation ev;
  ev.score = score;
  const auto kv = parseSummary(loopSummaryLine(ev), "VIMS_EVAL_LOOPS");
  EXPECT_EQ(kv.at("loop_trans_err_median_m"), "0.0060");
  EXPECT_EQ(kv.at("loop_trans_err_p90_m"), "0.0100");
}

TEST(EvalOptions, FromReaderValidatesKeys) {
  const auto o = EvalOptions::fromReader(vims::ConfigReader::fromString(
      "max_dt_s: 0.02\ninterpolate: true\nalign: [sim3, se3]\nrpe_delta_m: 5\nloop_rot_tol_deg: 3\n"
      "revisit_radius_m: 2.0\nrevisit_gap_s: 30\n"));
  EXPECT_DOUBLE_EQ(o.trajectory.association.max_dt_s, 0.02);
  EXPECT_TRUE(o.trajectory.association.interpolate);
  ASSERT_EQ(o.trajectory.alignments.size(), 2u);
  EXPECT_EQ(o.trajectory.alignments[0], AlignmentMode::kSim3);
  EXPECT_DOUBLE_EQ(o.trajectory.rpe_delta_m, 5.0);
  EXPECT_DOUBLE_EQ(o.loops.rot_tol_deg, 3.0);
  EXPECT_DOUBLE_EQ(o.revisit.radius_m, 2.0);
  EXPECT_DOUBLE_EQ(o.revisit.min_gap_s, 30.0);
  // The YAML it prints reads back to the same options.
  const auto back = EvalOptions::fromReader(vims::ConfigReader::fromString(o.toYaml()));
  EXPECT_EQ(back.toYaml(), o.toYaml());

  EXPECT_THROW(EvalOptions::fromReader(vims::ConfigReader::fromString("max_dt: 0.1\n")), vims::ConfigError);
  EXPECT_THROW(EvalOptions::fromReader(vims::ConfigReader::fromString("align: se2\n")), vims::ConfigError);
  EXPECT_THROW(EvalOptions::fromReader(vims::ConfigReader::fromString("revisit_radius_m: 0\n")), vims::ConfigError);
  EXPECT_THROW(EvalOptions::fromReader(vims::ConfigReader::fromString("loop_rot_tol_deg: 200\n")), vims::ConfigError);
  EXPECT_EQ(EvalOptions::fromReader(vims::ConfigReader::fromString("align: all\n")).trajectory.alignments.size(), 4u);
}
