#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "vims_eval/metrics.h"

using vims::StampedPose;
using namespace vims::eval;

namespace {

/// A 3-D survey-like path (T_w_b) with varying heading, roll and pitch, 10 Hz.
std::vector<StampedPose> makeGroundTruth(std::size_t n = 600) {
  std::vector<StampedPose> gt(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = 0.1 * static_cast<double>(i);
    gt[i].t = 100.0 + t;
    gt[i].p = Eigen::Vector3d(8.0 * std::cos(0.05 * t) + 0.3 * t, 5.0 * std::sin(0.08 * t), -3.0 + std::sin(0.03 * t));
    gt[i].q = Eigen::AngleAxisd(0.05 * t, Eigen::Vector3d::UnitZ()) *
              Eigen::AngleAxisd(0.1 * std::sin(0.2 * t), Eigen::Vector3d::UnitY()) *
              Eigen::AngleAxisd(0.05 * std::cos(0.3 * t), Eigen::Vector3d::UnitX());
  }
  return gt;
}

/// Zero-mean noise that is also uncorrelated with the centred positions: then the
/// least-squares alignment recovers the true transform exactly and the aligned ATE is
/// exactly the noise RMSE (the projection removes what an alignment could absorb).
std::vector<Eigen::Vector3d> orthogonalNoise(const std::vector<StampedPose>& gt, double sigma, unsigned seed) {
  const std::size_t n = gt.size();
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, sigma);
  Eigen::MatrixXd design(n, 4);
  Eigen::MatrixXd noise(n, 3);
  for (std::size_t i = 0; i < n; ++i) {
    design.row(i) << 1.0, gt[i].p.transpose();
    noise.row(i) << normal(rng), normal(rng), normal(rng);
  }
  noise -= design * design.colPivHouseholderQr().solve(noise);
  std::vector<Eigen::Vector3d> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i] = noise.row(i).transpose();
  return out;
}

/// est_v = S_v_w * gt (positions scaled about the origin, orientations rotated).
std::vector<StampedPose> transformed(const std::vector<StampedPose>& gt, const Eigen::Matrix3d& R_v_w,
                                     const Eigen::Vector3d& t_v_w, double scale) {
  std::vector<StampedPose> est = gt;
  for (auto& p : est) {
    p.p = scale * R_v_w * p.p + t_v_w;
    p.q = Eigen::Quaterniond(R_v_w * p.q.toRotationMatrix());
  }
  return est;
}

const Eigen::Matrix3d kRvw =
    (Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()))
        .toRotationMatrix();
const Eigen::Vector3d kTvw(12.0, -4.0, 7.5);

}  // namespace

TEST(ErrorStats, MatchesNumpyDefinitions) {
  const ErrorStats s = ErrorStats::compute({3.0, 1.0, 4.0, 2.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);  // mean of the two middle values
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(30.0 / 4.0));
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));  // population std
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(ErrorStats::compute({5.0, 1.0, 2.0}).median, 2.0);
  EXPECT_EQ(ErrorStats::compute({}).count, 0u);
}

TEST(Alignment, Se3AlignedAteEqualsNoiseRmse) {
  const auto gt = makeGroundTruth();
  const auto noise = orthogonalNoise(gt, 0.05, 7);
  std::vector<StampedPose> noisy = gt;
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    noisy[i].p += noise[i];
    sum_sq += noise[i].squaredNorm();
  }
  const double noise_rmse = std::sqrt(sum_sq / gt.size());
  ASSERT_GT(noise_rmse, 0.05);
  const auto est = transformed(noisy, kRvw, kTvw, 1.0);

  TrajectoryEvalOptions options;
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options, "vio");
  ASSERT_EQ(ev.associated.size(), gt.size());
  const AlignedErrors* se3 = ev.find(AlignmentMode::kSe3);
  ASSERT_NE(se3, nullptr);
  EXPECT_NEAR(se3->ate.rmse, noise_rmse, 1e-9);
  EXPECT_NEAR((se3->S_w_v.R_w_v - kRvw.transpose()).norm(), 0.0, 1e-9);
  EXPECT_NEAR((se3->S_w_v.t_w_v + kRvw.transpose() * kTvw).norm(), 0.0, 1e-9);
  EXPECT_DOUBLE_EQ(se3->S_w_v.scale, 1.0);
  EXPECT_NEAR(se3->rot.rmse, 0.0, 1e-6);  // orientations were not perturbed
  EXPECT_NEAR(se3->ate_rmse_pct, 100.0 * noise_rmse / pathLength(gt), 1e-9);
  // Unaligned, the error is dominated by the frame offset.
  EXPECT_GT(ev.find(AlignmentMode::kNone)->ate.rmse, 5.0);
}

TEST(Alignment, Sim3RecoversScaleWhileSe3AteIsLarger) {
  const auto gt = makeGroundTruth();
  const double scale_v = 0.8;  // the estimate is 20 % too small
  const auto est = transformed(gt, kRvw, kTvw, scale_v);
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, TrajectoryEvalOptions{}, "mono");
  const AlignedErrors* sim3 = ev.find(AlignmentMode::kSim3);
  const AlignedErrors* se3 = ev.find(AlignmentMode::kSe3);
  ASSERT_TRUE(sim3 && se3);
  EXPECT_NEAR(sim3->S_w_v.scale, 1.0 / scale_v, 1e-9);
  EXPECT_NEAR(sim3->ate.rmse, 0.0, 1e-9);
  EXPECT_NEAR(sim3->rot.rmse, 0.0, 1e-6);
  EXPECT_GT(se3->ate.rmse, 0.5);
}

TEST(Alignment, PosYawFixesYawAndTranslationOnly) {
  const auto gt = makeGroundTruth();
  const Eigen::Matrix3d R_yaw = Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto est_yaw = transformed(gt, R_yaw, kTvw, 1.0);
  const AlignedErrors yaw = evaluateAligned(gt, est_yaw, AlignmentMode::kPosYaw, 10.0);
  EXPECT_NEAR(yaw.ate.rmse, 0.0, 1e-9);
  EXPECT_NEAR((yaw.S_w_v.R_w_v - R_yaw.transpose()).norm(), 0.0, 1e-9);
  EXPECT_NEAR(yaw.rot.rmse, 0.0, 1e-6);

  // A tilt (roll/pitch error) cannot be removed by a 4-DoF alignment but can by SE3.
  const auto est_tilt = transformed(gt, kRvw, kTvw, 1.0);
  EXPECT_GT(evaluateAligned(gt, est_tilt, AlignmentMode::kPosYaw, 10.0).ate.rmse, 0.1);
  EXPECT_NEAR(evaluateAligned(gt, est_tilt, AlignmentMode::kSe3, 10.0).ate.rmse, 0.0, 1e-9);
}

TEST(Metrics, RotationRmseOfConstantOffset) {
  const auto gt = makeGroundTruth();
  std::vector<StampedPose> est = gt;
  const Eigen::Quaterniond q_offset(Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d(1, -1, 2).normalized()));
  for (auto& p : est) p.q = p.q * q_offset;  // a constant body-side rotation error of 3 deg
  const AlignedErrors r = evaluateAligned(gt, est, AlignmentMode::kSe3, 10.0);
  EXPECT_NEAR(r.ate.rmse, 0.0, 1e-9);
  EXPECT_NEAR(r.rot.rmse, 3.0, 1e-9);
  EXPECT_NEAR(r.rot.min, 3.0, 1e-9);
  EXPECT_NEAR(r.rot.max, 3.0, 1e-9);
}

TEST(Metrics, TiltErrorIsTheRollPitchPartOnly) {
  const auto gt = makeGroundTruth();
  std::vector<StampedPose> yawed = gt, tilted = gt;
  const Eigen::Quaterniond yaw(Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()));
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.7 * M_PI / 180.0, Eigen::Vector3d(1, 2, 0).normalized()));
  for (auto& p : yawed) p.q = yaw * p.q;    // a world-side yaw error: no tilt
  for (auto& p : tilted) p.q = tilt * p.q;  // the vertical off by 0.7 deg
  for (double e : tiltErrorsDeg(gt, yawed)) EXPECT_NEAR(e, 0.0, 1e-9);
  for (double e : tiltErrorsDeg(gt, tilted)) EXPECT_NEAR(e, 0.7, 1e-9);
  EXPECT_NEAR(evaluateAligned(gt, tilted, AlignmentMode::kNone, 10.0).tilt.rmse, 0.7, 1e-9);
}

// A vertical drift (the estimate sinks by 1 cm per metre of path) is a height error after the
// position-and-yaw alignment; SE3 tilts the estimate to fit it and leaves much less of it.
TEST(Metrics, HeightErrorShowsAVerticalDriftThatSe3Hides) {
  const auto gt = makeGroundTruth();
  std::vector<StampedPose> est = gt;
  double path = 0.0;
  std::vector<double> sink(gt.size(), 0.0);
  for (std::size_t i = 1; i < gt.size(); ++i) {
    path += (gt[i].p - gt[i - 1].p).norm();
    sink[i] = 1e-2 * path;
    est[i].p.z() -= sink[i];
  }
  // What the posyaw fit leaves: the sink minus its mean (the fit's vertical offset).
  double mean = 0.0;
  for (double s : sink) mean += s / sink.size();
  double expected = 0.0;
  for (double s : sink) expected += (s - mean) * (s - mean) / sink.size();
  expected = std::sqrt(expected);
  ASSERT_GT(expected, 0.01);
  const AlignedErrors posyaw = evaluateAligned(gt, est, AlignmentMode::kPosYaw, 10.0);
  EXPECT_NEAR(posyaw.height.rmse, expected, 1e-6);
  const std::vector<double> unaligned = heightErrors(gt, est);
  for (std::size_t i = 0; i < gt.size(); ++i) EXPECT_NEAR(unaligned[i], sink[i], 1e-12);
  const AlignedErrors se3 = evaluateAligned(gt, est, AlignmentMode::kSe3, 10.0);
  EXPECT_LT(se3.height.rmse, 0.7 * posyaw.height.rmse);  // measured 0.048 against 0.025 m
  RecordProperty("posyaw_height_m", std::to_string(posyaw.height.rmse));
  RecordProperty("se3_height_m", std::to_string(se3.height.rmse));
}

TEST(Metrics, RpePer10mOnStraightLineWithScaleError) {
  // 100 m along x at 1 m spacing; the estimate is 10 % too long.
  std::vector<StampedPose> gt(101), est(101);
  for (int i = 0; i <= 100; ++i) {
    gt[i].t = est[i].t = i;
    gt[i].p = Eigen::Vector3d(i, 0.0, 0.0);
    est[i].p = Eigen::Vector3d(1.1 * i, 0.0, 0.0);
  }
  // evo (consecutive pairs): kept indices 10, 20, ..., 100 -> 9 pairs.
  const auto pairs = pairsByPathLength(gt, 10.0);
  ASSERT_EQ(pairs.size(), 9u);
  EXPECT_EQ(pairs.front(), std::make_pair(std::size_t{10}, std::size_t{20}));
  EXPECT_EQ(pairs.back(), std::make_pair(std::size_t{90}, std::size_t{100}));

  const RpeResult rpe = computeRpe(gt, est, 10.0);
  EXPECT_NEAR(rpe.trans.rmse, 1.0, 1e-9);
  EXPECT_NEAR(rpe.trans.mean, 1.0, 1e-9);
  EXPECT_NEAR(rpe.rot.rmse, 0.0, 1e-9);
  // Invariant to SE3 alignment; Sim3 alignment removes the scale error.
  EXPECT_NEAR(evaluateAligned(gt, est, AlignmentMode::kSe3, 10.0).rpe.trans.rmse, 1.0, 1e-9);
  EXPECT_NEAR(evaluateAligned(gt, est, AlignmentMode::kSim3, 10.0).rpe.trans.rmse, 0.0, 1e-9);
  // A path shorter than two segments yields no pair (reported as "no data").
  std::vector<StampedPose> short_gt(gt.begin(), gt.begin() + 15), short_est(est.begin(), est.begin() + 15);
  EXPECT_EQ(computeRpe(short_gt, short_est, 10.0).trans.count, 0u);
}

TEST(Alignment, RejectsDegenerateInput) {
  std::vector<Eigen::Vector3d> still(5, Eigen::Vector3d(1, 2, 3));
  EXPECT_THROW(umeyamaAlignment(still, still, false), std::runtime_error);
  EXPECT_THROW(umeyamaAlignment({Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()},
                                {Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()}, true),
               std::runtime_error);
  std::vector<Eigen::Vector3d> vertical{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 1)};
  EXPECT_THROW(positionYawAlignment(vertical, vertical), std::runtime_error);
  EXPECT_EQ(parseAlignmentMode("posyaw"), AlignmentMode::kPosYaw);
  EXPECT_THROW(parseAlignmentMode("se2"), std::invalid_argument);
}
