// IMU preintegration against an analytic trajectory, the first-order bias correction against
// repropagation, the covariance against Monte Carlo, and the interval/bad-input handling.
#include <gtest/gtest.h>

#include <random>

#include "analytic_trajectory.h"
#include "test_utils.h"
#include "vims_estimator/imu_preintegration.h"
#include "vims_estimator/so3.h"

namespace vims {
namespace {

/// Noise of a tactical-grade MEMS IMU (the preintegration needs positive values; the ideal
/// trajectory samples below carry no noise).
ImuNoiseParams testNoise() {
  ImuNoiseParams n;
  n.gyro_noise_density = 1.7e-4;
  n.accel_noise_density = 2.0e-3;
  n.gyro_random_walk = 2.0e-5;
  n.accel_random_walk = 3.0e-3;
  return n;
}

/// IMU samples at `rate_hz` over [t_begin, t_end], optionally with timing jitter (uniform,
/// +-jitter_s) so that dt is non-uniform.
std::vector<ImuSample> sampleImu(const test::AnalyticTrajectory& traj, double t_begin, double t_end, double rate_hz,
                                 double jitter_s, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter_s, jitter_s);
  std::vector<ImuSample> out;
  const int n = static_cast<int>(std::lround((t_end - t_begin) * rate_hz));
  for (int k = 0; k <= n; ++k) out.push_back(traj.imu(t_begin + k / rate_hz + (k > 0 && k < n ? u(rng) : 0.0)));
  return out;
}

struct TrueDeltas {
  Eigen::Vector3d alpha, beta;
  Eigen::Quaterniond gamma;
};

TrueDeltas trueDeltas(const test::AnalyticTrajectory& traj, double ti, double tj) {
  const double T = tj - ti;
  const Eigen::Quaterniond q_i = traj.rotation(ti);
  const Eigen::Vector3d g = traj.gravityWorld();
  TrueDeltas d;
  d.alpha = q_i.conjugate() * (traj.position(tj) - traj.position(ti) - traj.velocity(ti) * T - 0.5 * g * T * T);
  d.beta = q_i.conjugate() * (traj.velocity(tj) - traj.velocity(ti) - g * T);
  d.gamma = q_i.conjugate() * traj.rotation(tj);
  return d;
}

TEST(AnalyticTrajectory, AngularRateAndSpecificForceAreConsistentWithTheMotion) {
  const test::AnalyticTrajectory traj;
  const double h = 1e-5;
  for (double t : {0.1, 0.77, 2.3}) {
    // R^T dR/dt = [omega_b]x
    const Eigen::Matrix3d dR =
        (traj.rotation(t + h).toRotationMatrix() - traj.rotation(t - h).toRotationMatrix()) / (2 * h);
    const Eigen::Matrix3d W = traj.rotation(t).toRotationMatrix().transpose() * dR;
    EXPECT_LT((W - so3::skew(traj.angularRateBody(t))).cwiseAbs().maxCoeff(), 1e-8);
    EXPECT_LT(((traj.position(t + h) - traj.position(t - h)) / (2 * h) - traj.velocity(t)).norm(), 1e-8);
    EXPECT_LT(((traj.velocity(t + h) - traj.velocity(t - h)) / (2 * h) - traj.acceleration(t)).norm(), 1e-8);
  }
  // At rest the accelerometer reads +g up.
  const test::AnalyticTrajectory rest =
      test::AnalyticTrajectory::constantVelocity(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0, 0.0);
  EXPECT_LT((rest.imu(0.3).accel - Eigen::Vector3d(0, 0, 9.81)).norm(), 1e-12);
}

// Mid-point integration reproduces the analytic relative motion. The rule is second order: its
// global error is ~dt^2/12 times the change of the rotated acceleration over the interval
// (~1e-6 at 200 Hz for this motion, with alpha ~0.05 m over 0.1 s and ~1 m over 1 s), so the
// tolerances below are that bound and, as the decisive check, the error must fall ~16x when the
// rate goes from 200 Hz to 800 Hz. A frame, sign or ordering error would be O(1e-2..1) and would
// not converge.
TEST(ImuPreintegration, MatchesAnalyticMotionOverShortAndLongIntervals) {
  const test::AnalyticTrajectory traj;
  struct Case {
    double ti, tj, jitter, tol_alpha, tol_beta, tol_gamma;
  };
  struct Errors {
    double alpha, beta, gamma;
  };
  auto integrate = [&](const Case& c, double rate) {
    const std::vector<ImuSample> buffer = sampleImu(traj, 0.0, 2.0, rate, c.jitter * 200.0 / rate, 7);
    const auto interval = imuSamplesForInterval(buffer, c.ti, c.tj);
    EXPECT_TRUE(interval.has_value());
    EXPECT_DOUBLE_EQ(interval->front().t, c.ti);
    EXPECT_DOUBLE_EQ(interval->back().t, c.tj);
    const ImuPreintegration pre =
        ImuPreintegration::fromSamples(*interval, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), testNoise());
    EXPECT_NEAR(pre.deltaTime(), c.tj - c.ti, 1e-12);
    const TrueDeltas truth = trueDeltas(traj, c.ti, c.tj);
    EXPECT_GT(truth.alpha.norm(), 0.04);  // the interval is not trivial
    return Errors{(pre.alpha() - truth.alpha).norm(), (pre.beta() - truth.beta).norm(),
                  so3::log(pre.gamma().conjugate() * truth.gamma).norm()};
  };
  int case_index = 0;
  for (const Case& c : {Case{0.3, 0.4, 0.0, 1e-6, 1e-5, 1e-6}, Case{0.3, 1.3, 0.0, 1e-5, 1e-5, 1e-5},
                        Case{0.3012, 1.3047, 1.0e-3, 1e-5, 1e-5, 1e-5}}) {
    const Errors e200 = integrate(c, 200.0);
    const Errors e800 = integrate(c, 800.0);
    const std::string label = "T=" + std::to_string(c.tj - c.ti) + " jitter=" + std::to_string(c.jitter);
    RecordProperty("alpha_error_200Hz_800Hz_case" + std::to_string(case_index++),
                   test::sci(e200.alpha) + " " + test::sci(e800.alpha));
    EXPECT_LT(e200.alpha, c.tol_alpha) << label;
    EXPECT_LT(e200.beta, c.tol_beta) << label;
    EXPECT_LT(e200.gamma, c.tol_gamma) << label;
    EXPECT_LT(e800.alpha, e200.alpha / 8.0) << label << " alpha " << e200.alpha << " -> " << e800.alpha;
    EXPECT_LT(e800.beta, e200.beta / 8.0) << label << " beta " << e200.beta << " -> " << e800.beta;
    EXPECT_LT(e800.gamma, e200.gamma / 8.0) << label << " gamma " << e200.gamma << " -> " << e800.gamma;
  }
}

// Samples carrying a constant bias, preintegrated at that bias, give the same deltas.
TEST(ImuPreintegration, ConstantBiasIsRemovedAtTheLinearisationPoint) {
  const test::AnalyticTrajectory traj;
  const Eigen::Vector3d ba(0.05, -0.08, 0.12), bg(0.01, -0.02, 0.015);
  std::vector<ImuSample> samples = sampleImu(traj, 0.5, 1.5, 200.0, 0.0, 1);
  for (auto& s : samples) {
    s.accel += ba;
    s.gyro += bg;
  }
  const ImuPreintegration pre = ImuPreintegration::fromSamples(samples, ba, bg, testNoise());
  const TrueDeltas truth = trueDeltas(traj, 0.5, 1.5);
  EXPECT_LT((pre.alpha() - truth.alpha).norm(), 1e-5);  // the mid-point bound of the test above
  EXPECT_LT((pre.beta() - truth.beta).norm(), 1e-5);
  EXPECT_LT(so3::log(pre.gamma().conjugate() * truth.gamma).norm(), 1e-5);
}

// The first-order bias correction agrees with repropagation up to second-order terms: the error
// is small and shrinks 4x when the bias change halves.
TEST(ImuPreintegration, FirstOrderBiasCorrectionMatchesRepropagation) {
  const test::AnalyticTrajectory traj;
  const std::vector<ImuSample> samples = sampleImu(traj, 0.2, 1.2, 200.0, 1e-3, 3);
  const Eigen::Vector3d ba0(0.02, -0.01, 0.03), bg0(0.002, 0.001, -0.003);
  const ImuPreintegration pre = ImuPreintegration::fromSamples(samples, ba0, bg0, testNoise());

  const Eigen::Vector3d dba(0.08, -0.05, 0.06), dbg(0.012, -0.009, 0.015);
  double previous_error = 0.0;
  for (double scale : {1.0, 0.5}) {
    const Eigen::Vector3d ba = ba0 + scale * dba, bg = bg0 + scale * dbg;
    Eigen::Vector3d alpha_c, beta_c;
    Eigen::Quaterniond gamma_c;
    pre.correct(ba, bg, &alpha_c, &beta_c, &gamma_c);
    ImuPreintegration re = pre;
    re.repropagate(ba, bg);

    const double change = (re.alpha() - pre.alpha()).norm() + (re.beta() - pre.beta()).norm() +
                          so3::log(pre.gamma().conjugate() * re.gamma()).norm();
    const double error =
        (alpha_c - re.alpha()).norm() + (beta_c - re.beta()).norm() + so3::log(gamma_c.conjugate() * re.gamma()).norm();
    EXPECT_GT(change, scale * 0.05);  // the bias change matters ...
    EXPECT_LT(error, 0.01 * change);  // ... and the linear correction captures > 99 % of it
    if (scale == 0.5) {
      EXPECT_NEAR(previous_error / error, 4.0, 0.6);  // second-order remainder
    }
    previous_error = error;
  }
}

TEST(ImuPreintegration, RepropagatesOnlyBeyondTheBiasThresholds) {
  const test::AnalyticTrajectory traj;
  ImuPreintegration pre = ImuPreintegration::fromSamples(sampleImu(traj, 0.0, 0.5, 200.0, 0.0, 1),
                                                         Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), testNoise());
  ImuPreintegrationOptions o;
  EXPECT_FALSE(pre.repropagateIfNeeded(Eigen::Vector3d(0.5 * o.max_accel_bias_change, 0, 0),
                                       Eigen::Vector3d(0, 0.5 * o.max_gyro_bias_change, 0), o));
  EXPECT_TRUE(pre.linearizedGyroBias().isZero());
  const Eigen::Vector3d bg(0, 0, 2.0 * o.max_gyro_bias_change);
  EXPECT_TRUE(pre.repropagateIfNeeded(Eigen::Vector3d::Zero(), bg, o));
  EXPECT_EQ(pre.linearizedGyroBias(), bg);
}

// Monte Carlo: noisy samples (white noise of the given densities at 200 Hz and bias random walks)
// preintegrated at the initial true bias; the sample covariance of the factor residual at the true
// states is compared with the propagated covariance through the mean NEES (all 15 dimensions and
// their correlations) and the diagonal (each within 20 %).
TEST(ImuPreintegration, CovarianceMatchesMonteCarlo) {
  const test::AnalyticTrajectory traj;
  ImuNoiseParams noise;
  noise.gyro_noise_density = 2e-3;
  noise.accel_noise_density = 2e-2;
  noise.gyro_random_walk = 1e-3;  // large random walks so the bias coupling shows within 1 s
  noise.accel_random_walk = 1e-2;
  const double rate = 200.0, ti = 0.4, tj = 1.4;
  const double dt = 1.0 / rate;
  const int runs = 1000;
  const std::vector<ImuSample> clean = sampleImu(traj, ti, tj, rate, 0.0, 1);
  const TrueDeltas truth = trueDeltas(traj, ti, tj);

  std::mt19937 rng(12345);
  std::normal_distribution<double> n01(0.0, 1.0);
  auto gauss = [&](double s) { return Eigen::Vector3d(s * n01(rng), s * n01(rng), s * n01(rng)); };

  std::vector<Eigen::Matrix<double, 15, 1>> errors;
  Matrix15d P = Matrix15d::Zero();
  for (int run = 0; run < runs; ++run) {
    Eigen::Vector3d ba = gauss(0.05), bg = gauss(0.005);  // true initial biases, linearised exactly
    const Eigen::Vector3d ba_i = ba, bg_i = bg;
    std::vector<ImuSample> noisy = clean;
    for (size_t k = 0; k < noisy.size(); ++k) {
      if (k > 0) {
        ba += gauss(noise.accel_random_walk * std::sqrt(dt));
        bg += gauss(noise.gyro_random_walk * std::sqrt(dt));
      }
      noisy[k].accel += ba + gauss(noise.accel_noise_density / std::sqrt(dt));
      noisy[k].gyro += bg + gauss(noise.gyro_noise_density / std::sqrt(dt));
    }
    const ImuPreintegration pre = ImuPreintegration::fromSamples(noisy, ba_i, bg_i, noise);
    if (run == 0) P = pre.covariance();
    Eigen::Matrix<double, 15, 1> e;
    e.segment<3>(kIdxAlpha) = truth.alpha - pre.alpha();
    e.segment<3>(kIdxTheta) = so3::log(pre.gamma().conjugate() * truth.gamma);
    e.segment<3>(kIdxBeta) = truth.beta - pre.beta();
    e.segment<3>(kIdxBa) = ba - ba_i;
    e.segment<3>(kIdxBg) = bg - bg_i;
    errors.push_back(e);
  }
  Matrix15d C = Matrix15d::Zero();
  for (const auto& e : errors) C += e * e.transpose();
  C /= runs;

  const Matrix15d P_inv = P.inverse();
  double nees = 0.0;
  for (const auto& e : errors) nees += e.dot(P_inv * e);
  nees /= runs;
  RecordProperty("mean_nees", test::sci(nees));
  EXPECT_NEAR(nees, 15.0, 1.5) << "mean NEES";  // a factor-2 error in any block moves it far more
  for (int i = 0; i < 15; ++i) {
    EXPECT_NEAR(C(i, i) / P(i, i), 1.0, 0.2) << "diagonal " << i;
  }
  // The bias coupling is real (correlation alpha-b_a), so the off-diagonal blocks were exercised.
  const double corr = P(kIdxAlpha, kIdxBa) / std::sqrt(P(kIdxAlpha, kIdxAlpha) * P(kIdxBa, kIdxBa));
  EXPECT_GT(std::abs(corr), 0.1);
}

// Covariance does not depend on the IMU rate (the densities are discretised with dt).
TEST(ImuPreintegration, CovarianceIsRateIndependent) {
  const test::AnalyticTrajectory traj;
  const ImuPreintegration p200 = ImuPreintegration::fromSamples(
      sampleImu(traj, 0.0, 1.0, 200.0, 0.0, 1), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), testNoise());
  const ImuPreintegration p800 = ImuPreintegration::fromSamples(
      sampleImu(traj, 0.0, 1.0, 800.0, 0.0, 1), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), testNoise());
  for (int i = 0; i < 15; ++i) EXPECT_NEAR(p800.covariance()(i, i) / p200.covariance()(i, i), 1.0, 0.02) << i;
}

TEST(ImuPreintegration, IntervalExtractionAndBadInput) {
  const test::AnalyticTrajectory traj;
  const std::vector<ImuSample> buffer = sampleImu(traj, 0.0, 1.0, 200.0, 0.0, 1);
  EXPECT_FALSE(imuSamplesForInterval(buffer, -0.1, 0.5).has_value());  // starts before the data
  EXPECT_FALSE(imuSamplesForInterval(buffer, 0.5, 1.2).has_value());   // ends after the data
  EXPECT_FALSE(imuSamplesForInterval(buffer, 0.5, 0.5).has_value());   // empty interval
  // Endpoints on samples are copied, not interpolated.
  const auto exact = imuSamplesForInterval(buffer, 0.1, 0.2);
  ASSERT_TRUE(exact.has_value());
  EXPECT_EQ(exact->size(), 21u);
  // A boundary between samples is interpolated linearly.
  const auto mid = imuSamplesForInterval(buffer, 0.1025, 0.2);
  ASSERT_TRUE(mid.has_value());
  EXPECT_LT((mid->front().gyro - 0.5 * (buffer[20].gyro + buffer[21].gyro)).norm(), 1e-12);
  // A NaN inside the interval is rejected.
  std::vector<ImuSample> bad = buffer;
  bad[30].accel.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(imuSamplesForInterval(bad, 0.1, 0.2).has_value());

  ImuPreintegration pre(buffer[0], Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), testNoise());
  EXPECT_TRUE(pre.addSample(buffer[1]));
  EXPECT_FALSE(pre.addSample(buffer[1]));  // time does not advance
  EXPECT_FALSE(pre.addSample(buffer[0]));  // time goes backwards
  ImuSample nan_sample = buffer[2];
  nan_sample.gyro.y() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(pre.addSample(nan_sample));
  EXPECT_TRUE(pre.addSample(buffer[2]));
  EXPECT_EQ(pre.numSteps(), 2);
  EXPECT_TRUE(pre.covariance().allFinite());

  ImuCalibration calib;  // all-zero noise: unusable for a factor
  EXPECT_THROW(ImuNoiseParams::fromCalibration(calib), std::invalid_argument);
}

}  // namespace
}  // namespace vims
