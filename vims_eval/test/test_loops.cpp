#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "vims_eval/loops.h"

using vims::StampedPose;
using namespace vims::eval;

namespace {

constexpr double kDeg = M_PI / 180.0;

/// 100 s at 10 Hz along x at 1 m/s, yawing slowly, so relative poses have rotation too.
std::vector<StampedPose> groundTruth() {
  std::vector<StampedPose> gt;
  for (int i = 0; i <= 1000; ++i) {
    StampedPose p;
    p.t = 0.1 * i;
    p.p = Eigen::Vector3d(p.t, 0.2 * p.t, -5.0);
    p.q = Eigen::Quaterniond(Eigen::AngleAxisd(0.01 * p.t, Eigen::Vector3d::UnitZ()));
    gt.push_back(p);
  }
  return gt;
}

/// T_match_query of the ground truth, computed independently of the scorer (isometries).
Eigen::Isometry3d trueRelative(double t_query, double t_match) {
  auto pose = [](double t) {
    Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
    T_w_b.translation() = Eigen::Vector3d(t, 0.2 * t, -5.0);
    T_w_b.linear() = Eigen::AngleAxisd(0.01 * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return T_w_b;
  };
  return pose(t_match).inverse() * pose(t_query);
}

LoopRecord loop(double t_query, double t_match, bool accepted, const Eigen::Isometry3d& T_match_query) {
  LoopRecord r;
  r.t_query = t_query;
  r.t_match = t_match;
  r.accepted = accepted;
  r.T_match_query = T_match_query;
  return r;
}

Eigen::Isometry3d shifted(Eigen::Isometry3d T, const Eigen::Vector3d& dp) {
  T.translation() += dp;
  return T;
}

Eigen::Isometry3d rotated(Eigen::Isometry3d T, double angle_deg) {
  T.linear() =
      T.linear() * Eigen::AngleAxisd(angle_deg * kDeg, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  return T;
}

std::vector<LoopRecord> parse(const std::string& text) {
  std::istringstream in(text);
  return parseLoopCsv(in, "loops.csv");
}

void expectParseError(const std::string& text, const std::string& fragment) {
  try {
    parse(text);
    FAIL() << "expected an error containing '" << fragment << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

const char* kHeader = "t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,bow_score,stage\n";

}  // namespace

TEST(LoopScoring, CorrectAndWrongByTranslationAndRotationTolerance) {
  const auto gt = groundTruth();
  // t_query 50.05 lies between ground-truth samples: the truth is interpolated.
  const Eigen::Isometry3d T = trueRelative(50.05, 10.0);
  const std::vector<LoopRecord> records = {
      loop(50.05, 10.0, true, T),                                            // exact: correct
      loop(50.05, 10.0, true, shifted(T, Eigen::Vector3d(0.3, 0.0, 0.25))),  // 0.39 m: correct
      loop(50.05, 10.0, true, shifted(T, Eigen::Vector3d(0.0, 0.6, 0.0))),   // 0.6 m: wrong
      loop(50.05, 10.0, true, rotated(T, 4.0)),                              // 4 deg: correct
      loop(50.05, 10.0, true, rotated(T, 6.0)),                              // 6 deg: wrong
      loop(50.05, 10.0, false, T),                                           // rejected, but right
      loop(50.05, 10.0, false, rotated(T, 30.0)),                            // rejected and wrong
      loop(150.0, 10.0, true, T),                                            // no ground truth at t_query
  };
  const LoopScore score = scoreLoops(records, gt, LoopScoringOptions{});
  EXPECT_EQ(score.verifications, 8u);
  EXPECT_EQ(score.accepted, 6u);
  EXPECT_EQ(score.correct, 3u);
  EXPECT_EQ(score.wrong, 2u);
  EXPECT_EQ(score.accepted_no_gt, 1u);
  EXPECT_EQ(score.rejected_correct, 1u);
  EXPECT_NEAR(score.precision(), 3.0 / 5.0, 1e-12);
  ASSERT_EQ(score.loops.size(), 8u);
  EXPECT_NEAR(score.loops[0].trans_error_m, 0.0, 1e-9);
  EXPECT_NEAR(score.loops[0].rot_error_deg, 0.0, 1e-6);
  EXPECT_NEAR(score.loops[1].trans_error_m, std::hypot(0.3, 0.25), 1e-9);
  EXPECT_NEAR(score.loops[3].rot_error_deg, 4.0, 1e-9);
  EXPECT_NEAR(score.loops[4].rot_error_deg, 6.0, 1e-9);
  EXPECT_FALSE(score.loops[7].has_gt);

  // Tighter tolerances turn the 0.39 m and 4 deg loops into wrong ones.
  LoopScoringOptions strict;
  strict.trans_tol_m = 0.2;
  strict.rot_tol_deg = 2.0;
  const LoopScore strict_score = scoreLoops(records, gt, strict);
  EXPECT_EQ(strict_score.correct, 1u);
  EXPECT_EQ(strict_score.wrong, 4u);
}

TEST(LoopCsv, ParsesRowsInAnyColumnOrder) {
  const auto records = parse(std::string(kHeader) +
                             "# a comment\n"
                             "50.5,10.25,1,1.5,-2,0.25,0,0,0.70710678,0.70710678,87,1.2e-7,0.031,geometric\n"
                             "\n"
                             "60,20,false,0,0,0,0,0,0,1,,nan,,bow\n");
  ASSERT_EQ(records.size(), 2u);
  EXPECT_EQ(records[0].line, 3);
  EXPECT_DOUBLE_EQ(records[0].t_query, 50.5);
  EXPECT_DOUBLE_EQ(records[0].t_match, 10.25);
  EXPECT_TRUE(records[0].accepted);
  EXPECT_NEAR((records[0].T_match_query.translation() - Eigen::Vector3d(1.5, -2, 0.25)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(records[0].T_match_query.linear()).angle(), M_PI / 2, 1e-6);
  EXPECT_EQ(records[0].inliers, 87);
  EXPECT_DOUBLE_EQ(records[0].mag_distance, 1.2e-7);
  EXPECT_EQ(records[0].stage, "geometric");
  EXPECT_FALSE(records[1].accepted);
  EXPECT_EQ(records[1].inliers, -1);
  EXPECT_TRUE(std::isnan(records[1].mag_distance));
  EXPECT_TRUE(std::isnan(records[1].bow_score));

  const auto reordered = parse(
      "stage,qw,qx,qy,qz,x,y,z,t_match,t_query,accepted,inliers,bow_score,mag_distance,extra\n"
      "pnp,1,0,0,0,3,4,5,1,2,1,10,0.5,0.1,ignored\n");
  ASSERT_EQ(reordered.size(), 1u);
  EXPECT_DOUBLE_EQ(reordered[0].t_query, 2.0);
  EXPECT_DOUBLE_EQ(reordered[0].T_match_query.translation().z(), 5.0);
  EXPECT_EQ(reordered[0].stage, "pnp");
}

TEST(LoopCsv, ReportsErrorsWithLineNumbers) {
  expectParseError("t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,stage\n",
                   "loops.csv:1: header lacks column 'bow_score'");
  expectParseError(std::string(kHeader) + "1,2,1,0,0,0,0,0,0,1,5,0.1,0.2\n", "loops.csv:2: expected 14 fields, got 13");
  expectParseError(std::string(kHeader) + "1,2,1,0,0,0,0,0,0,1,5,0.1,0.2,s\n1,2,1,0,abc,0,0,0,0,1,5,0.1,0.2,s\n",
                   "loops.csv:3: column 'y': 'abc' is not a number");
  expectParseError(std::string(kHeader) + "1,2,maybe,0,0,0,0,0,0,1,5,0.1,0.2,s\n", "loops.csv:2: column 'accepted'");
  expectParseError(std::string(kHeader) + "1,2,1,0,0,0,0,0,0,0,5,0.1,0.2,s\n", "loops.csv:2: zero quaternion");
  expectParseError(std::string(kHeader) + "1,2,1,0,0,nan,0,0,0,1,5,0.1,0.2,s\n",
                   "loops.csv:2: column 'z': value must be finite");
  expectParseError(std::string(kHeader) + "1,2,1,0,0,0,0,0,0,1,5.5,0.1,0.2,s\n", "loops.csv:2: column 'inliers'");
  expectParseError("", "no header row");
  EXPECT_THROW(readLoopCsv("/nonexistent/loops.csv"), std::runtime_error);
  EXPECT_TRUE(parse(kHeader).empty());  // a run without any verification attempt
}

TEST(LoopScoring, ALoopIntoALoadedMapIsScoredAgainstTheMapsRunOrNotAtAll) {
  const auto gt = groundTruth();
  // The map's run: the same world, the same stamps, but 40 m further along x. A loop from the
  // run's t = 50 into the map's t = 10 is right when it matches the map run's truth there.
  std::vector<StampedPose> map_gt = gt;
  for (auto& p : map_gt) p.p.x() += 40.0;
  Eigen::Isometry3d T_w_match = Eigen::Isometry3d::Identity();
  T_w_match.translation() = map_gt[100].p;
  T_w_match.linear() = map_gt[100].q.toRotationMatrix();
  Eigen::Isometry3d T_w_query = Eigen::Isometry3d::Identity();
  T_w_query.translation() = gt[500].p;
  T_w_query.linear() = gt[500].q.toRotationMatrix();
  LoopRecord into_map = loop(50.0, 10.0, true, T_w_match.inverse() * T_w_query);
  into_map.match_in_map = true;
  const LoopScore with_map = scoreLoops({into_map}, gt, LoopScoringOptions{}, &map_gt);
  EXPECT_EQ(with_map.correct, 1u);
  EXPECT_EQ(with_map.wrong, 0u);
  // Against the run's own truth it would be 40 m off; without the map's truth it is not scored.
  const LoopScore without_map = scoreLoops({into_map}, gt, LoopScoringOptions{});
  EXPECT_EQ(without_map.accepted_no_gt, 1u);
  EXPECT_EQ(without_map.wrong, 0u);
  into_map.match_in_map = false;
  EXPECT_EQ(scoreLoops({into_map}, gt, LoopScoringOptions{}, &map_gt).wrong, 1u);
}

TEST(LoopCsv, ReadsTheOptionalMatchInMapColumn) {
  EXPECT_FALSE(parse(std::string(kHeader) + "5,1,1,0,0,0,0,0,0,1,30,,,accepted\n").at(0).match_in_map);
  const auto rows = parse(
      "t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,bow_score,stage,match_in_map\n"
      "5,1,1,0,0,0,0,0,0,1,30,,,accepted,1\n5,2,1,0,0,0,0,0,0,1,30,,,accepted,0\n");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_TRUE(rows[0].match_in_map);
  EXPECT_FALSE(rows[1].match_in_map);
  expectParseError(
      "t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,bow_score,stage,match_in_map\n"
      "5,1,1,0,0,0,0,0,0,1,30,,,accepted,maybe\n",
      "match_in_map");
}
