// Teach and repeat scoring (relocalisation.h) on synthetic runs whose answers are known.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "vims_eval/relocalisation.h"

using namespace vims;
using namespace vims::eval;
namespace fs = std::filesystem;

namespace {

/// The teach run: a 10 m x 5 m ellipse at 8 m depth, 20 Hz for 80 s.
std::vector<StampedPose> teachTruth() {
  std::vector<StampedPose> gt;
  for (int i = 0; i <= 1600; ++i) {
    StampedPose p;
    p.t = 1000.0 + 0.05 * i;
    const double a = 2 * M_PI * (p.t - 1000.0) / 80.0;
    p.p = Eigen::Vector3d(10.0 * std::cos(a), 5.0 * std::sin(a), -8.0);
    gt.push_back(p);
  }
  return gt;
}

/// The repeat run: from (30, 0) westwards along y = 0 at 0.5 m/s; it reaches the ellipse's
/// eastern end (10, 0), i.e. 1 m from it at x = 11, after 38 s.
std::vector<StampedPose> repeatTruth() {
  std::vector<StampedPose> gt;
  for (int i = 0; i <= 1200; ++i) {
    StampedPose p;
    p.t = 2000.0 + 0.05 * i;
    p.p = Eigen::Vector3d(30.0 - 0.5 * (p.t - 2000.0), 0.0, -8.0);
    gt.push_back(p);
  }
  return gt;
}

/// A run's poses in the map's frame: the world rotated by -30 deg about z and shifted, as a map
/// started elsewhere with another heading would be; every second pose, offset by `offset_w`.
std::vector<StampedPose> inMapFrame(const std::vector<StampedPose>& gt, const Eigen::Vector3d& offset_w) {
  const Eigen::Matrix3d R_map_w = Eigen::AngleAxisd(-M_PI / 6, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d t_map_w(4.0, -2.0, 1.0);
  std::vector<StampedPose> est;
  for (std::size_t i = 0; i < gt.size(); i += 2) {
    StampedPose p = gt[i];
    p.p = R_map_w * (gt[i].p + offset_w) + t_map_w;
    est.push_back(p);
  }
  return est;
}

}  // namespace

TEST(Relocalisation, ScoresARepeatRunInTheTeachMapsFrame) {
  const auto teach_gt = teachTruth(), repeat_gt = repeatTruth();
  // The teach run is exact; the repeat run 0.1 m off east after relocalising at t = 2040.
  const RelocalisationEvaluation ev =
      evaluateRelocalisation(teach_gt, inMapFrame(teach_gt, Eigen::Vector3d::Zero()), repeat_gt,
                             inMapFrame(repeat_gt, Eigen::Vector3d(0.1, 0, 0)), {true, 2040.0}, {});
  ASSERT_TRUE(ev.t_entered.has_value());
  EXPECT_NEAR(*ev.t_entered, 2038.0, 0.06);
  EXPECT_TRUE(ev.relocalised);
  EXPECT_NEAR(ev.delay_s, 2.0, 0.06);
  EXPECT_TRUE(ev.correct);
  EXPECT_NEAR(ev.error_at_relocalisation_m, 0.1, 1e-6);
  EXPECT_NEAR(ev.ate_after_rmse_m, 0.1, 1e-6);
  EXPECT_NEAR(ev.teach_ate_rmse_m, 0.0, 1e-6);
  EXPECT_EQ(ev.poses_after, 201u);  // 2040 ... 2060 s, every 0.1 s
  EXPECT_NE(ev.summaryLine().find("VIMS_EVAL_RELOC relocalised=1 correct=1 entered=1"), std::string::npos)
      << ev.summaryLine();
}

TEST(Relocalisation, PassingBesideTheMapIsNotEnteringIt) {
  // 1.4 m east of the ellipse's eastern end, moving east, then from t = 3010 hovering 0.5 m
  // inside the track: it enters at 3010 (1 m radius), or at once with a 1.5 m one.
  const auto teach_gt = teachTruth();
  std::vector<StampedPose> repeat_gt;
  for (int i = 0; i <= 400; ++i) {
    StampedPose p;
    p.t = 3000.0 + 0.05 * i;
    p.p = p.t < 3010.0 ? Eigen::Vector3d(11.4 + 0.5 * (p.t - 3000.0), 0.0, -8.0) : Eigen::Vector3d(9.5, 0.0, -8.0);
    repeat_gt.push_back(p);
  }
  const auto teach_est = inMapFrame(teach_gt, Eigen::Vector3d::Zero());
  const auto repeat_est = inMapFrame(repeat_gt, Eigen::Vector3d::Zero());
  const RelocalisationEvaluation ev = evaluateRelocalisation(teach_gt, teach_est, repeat_gt, repeat_est, {}, {});
  ASSERT_TRUE(ev.t_entered.has_value());
  EXPECT_NEAR(*ev.t_entered, 3010.0, 1e-6);
  RelocalisationOptions wide;
  wide.map_radius_m = 1.5;
  const auto beside = evaluateRelocalisation(teach_gt, teach_est, repeat_gt, repeat_est, {}, wide).t_entered;
  ASSERT_TRUE(beside.has_value());
  EXPECT_NEAR(*beside, 3000.0, 1e-6);
}

TEST(Relocalisation, ARelocalisationAtTheWrongPlaceIsWrong) {
  const auto teach_gt = teachTruth(), repeat_gt = repeatTruth();
  const RelocalisationEvaluation ev =
      evaluateRelocalisation(teach_gt, inMapFrame(teach_gt, Eigen::Vector3d::Zero()), repeat_gt,
                             inMapFrame(repeat_gt, Eigen::Vector3d(0, 2.0, 0)), {true, 2040.0}, {});
  EXPECT_TRUE(ev.relocalised);
  EXPECT_FALSE(ev.correct);
  EXPECT_NEAR(ev.error_at_relocalisation_m, 2.0, 1e-6);
  // A looser tolerance accepts it.
  RelocalisationOptions loose;
  loose.correct_tol_m = 2.5;
  EXPECT_TRUE(evaluateRelocalisation(teach_gt, inMapFrame(teach_gt, Eigen::Vector3d::Zero()), repeat_gt,
                                     inMapFrame(repeat_gt, Eigen::Vector3d(0, 2.0, 0)), {true, 2040.0}, loose)
                  .correct);
}

TEST(Relocalisation, ARunThatNeverRelocalisesOrNeverEntersSaysSo) {
  const auto teach_gt = teachTruth();
  auto far = repeatTruth();
  for (auto& p : far) p.p.y() += 20.0;  // passes 15 m north of the ellipse
  const RelocalisationEvaluation ev = evaluateRelocalisation(teach_gt, inMapFrame(teach_gt, Eigen::Vector3d::Zero()),
                                                             far, inMapFrame(far, Eigen::Vector3d::Zero()), {}, {});
  EXPECT_FALSE(ev.t_entered.has_value());
  EXPECT_FALSE(ev.relocalised);
  EXPECT_FALSE(ev.correct);
  EXPECT_EQ(ev.poses_after, 0u);
  EXPECT_DOUBLE_EQ(ev.ratio(), 0.0);
  EXPECT_NE(ev.summaryLine().find("relocalised=0 correct=0 entered=0"), std::string::npos);
  // Without a teach trajectory there is no map frame: an error, not a figure.
  EXPECT_THROW(evaluateRelocalisation(teach_gt, {}, far, {}, {}, {}), std::runtime_error);
}

TEST(Relocalisation, ReadsTheReportOfASummaryAndNamesWhatIsMissing) {
  const fs::path dir = fs::path(::testing::TempDir()) / "relocalisation_summary";
  fs::create_directories(dir);
  const std::string path = (dir / "summary.yaml").string();
  std::ofstream(path) << "pose_graph: {keyframes: 10, relocalised: true, relocalised_t: 1700000012.345}\n";
  const RelocalisationReport report = readRelocalisationReport(path);
  EXPECT_TRUE(report.relocalised);
  EXPECT_DOUBLE_EQ(report.t_relocalised, 1700000012.345);
  std::ofstream(path) << "pose_graph: {keyframes: 10, relocalised: false}\n";
  EXPECT_FALSE(readRelocalisationReport(path).relocalised);
  std::ofstream(path) << "pose_graph: {keyframes: 10, relocalised: true}\n";
  try {
    readRelocalisationReport(path);
    FAIL() << "a relocalised run without its time must be an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("relocalised_t"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "vio: {frames: 3}\n";
  EXPECT_THROW(readRelocalisationReport(path), std::runtime_error);
  EXPECT_THROW(readRelocalisationReport((dir / "absent.yaml").string()), std::runtime_error);
}
