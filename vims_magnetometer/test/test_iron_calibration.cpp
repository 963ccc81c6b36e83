// The hard- and soft-iron fit (iron_calibration.h), its options, and the front end applying it.
#include <gtest/gtest.h>

#include <random>

#include "synthetic_vehicle.h"
#include "vims_magnetometer/iron_calibration.h"
#include "vims_magnetometer/magnetic_front_end.h"
#include "vims_magnetometer/magnetometer_options.h"

using namespace vims;
using vims_test::Streams;
using vims_test::World;

namespace {

const Eigen::Vector3d kFieldEnu(1.9e-6, 2.0e-5, -4.4e-5);  // 48.4 uT, inclination 65 deg
constexpr double kGravity = 9.81;

/// 5 uT of hard iron and soft iron of up to 5 %, in the mag frame.
Eigen::Matrix3d softIron() {
  Eigen::Matrix3d W;
  W << 1.04, 0.02, -0.015, 0.02, 0.97, 0.03, -0.015, 0.03, 1.05;
  return W;
}
const Eigen::Vector3d kHardIron = Eigen::Vector3d(3.0e-6, -3.5e-6, 1.8e-6);

/// A calibration tumble: `n` blocks at uniformly random attitudes, measured through the iron.
std::vector<IronFitSample> tumble(int n, const Eigen::Matrix3d& W, const Eigen::Vector3d& b, double noise) {
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<IronFitSample> out;
  for (int i = 0; i < n; ++i) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized();
    IronFitSample s;
    s.field_t = W * (q.conjugate() * kFieldEnu) + b + noise * Eigen::Vector3d(g(rng), g(rng), g(rng));
    out.push_back(s);
  }
  return out;
}

/// Level turns through `turn_deg` of heading, pitched by trim_deg + slope_deg cos(heading) (a
/// vehicle flying nose-down, holding altitude over a slope), with the accelerometer showing it.
std::vector<IronFitSample> levelTurns(double turn_deg, double slope_deg, const Eigen::Matrix3d& W,
                                      const Eigen::Vector3d& b, double trim_deg = 0.0) {
  std::vector<IronFitSample> out;
  const int n = 400;
  for (int i = 0; i < n; ++i) {
    const double yaw = turn_deg * M_PI / 180.0 * i / (n - 1);
    const double pitch = (trim_deg + slope_deg * std::cos(yaw)) * M_PI / 180.0;
    const Eigen::Matrix3d R =
        (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
            .toRotationMatrix();
    IronFitSample s;
    s.field_t = W * (R.transpose() * kFieldEnu) + b;
    s.specific_force = R.transpose() * Eigen::Vector3d(0, 0, kGravity);
    s.has_specific_force = true;
    out.push_back(s);
  }
  return out;
}

}  // namespace

TEST(IronFit, FullFitFromATumbleRecoversHardAndSoftIron) {
  const auto samples = tumble(400, softIron(), kHardIron, 20e-9);
  IronFitOptions options;
  options.site_field_t = kFieldEnu.norm();
  const IronFitResult fit = fitIronCorrection(samples, options);
  ASSERT_TRUE(fit.ok) << fit.why;
  EXPECT_EQ(fit.model, IronFitModel::kFull);
  EXPECT_GT(fit.spread_ratio, 0.5);
  const Eigen::Matrix3d KW = fit.correction.soft_iron_inverse * softIron();
  EXPECT_LT((KW - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT((fit.correction.hard_iron_t - kHardIron).norm(), 30e-9);
  EXPECT_GT(fit.rms_before_t, 1e-6);  // the raw magnitude swings by microtesla
  EXPECT_LT(fit.rms_after_t, 40e-9);  // down to the 20 nT noise (x sqrt(3) for three axes at most)
  // The file vims_mag_calib writes reads back as the same correction.
  const auto read_back = MagnetometerOptions::fromReader(
      ConfigReader::fromString(ironCorrectionConfigYaml(fit), "iron.yaml").child("magnetometer"));
  EXPECT_EQ(read_back.iron_correction.hard_iron_t, fit.correction.hard_iron_t);
  EXPECT_EQ(read_back.iron_correction.soft_iron_inverse, fit.correction.soft_iron_inverse);

  // Without the site's field the overall scale stays the sensor's: K W is a multiple of I.
  const IronFitResult free_scale = fitIronCorrection(samples, IronFitOptions{});
  ASSERT_TRUE(free_scale.ok) << free_scale.why;
  const Eigen::Matrix3d KW2 = free_scale.correction.soft_iron_inverse * softIron();
  const double s = KW2.trace() / 3.0;
  EXPECT_NEAR(free_scale.correction.soft_iron_inverse.trace(), 3.0, 1e-9);
  EXPECT_LT((KW2 / s - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_NEAR(free_scale.field_t, s * kFieldEnu.norm(), 1e-9);
}

TEST(IronFit, LevelTurnsGiveTheHorizontalFitAndTheTiltIsLevelledNotFitted) {
  // Soft and hard iron in x-y only (what level turns can see).
  Eigen::Matrix3d W = Eigen::Matrix3d::Identity();
  W.topLeftCorner<2, 2>() << 1.04, 0.02, 0.02, 0.96;
  const Eigen::Vector3d b(4e-6, -3e-6, 0.0);
  const auto samples = levelTurns(720.0, 4.0, W, b);
  const IronFitResult fit = fitIronCorrection(samples, IronFitOptions{});
  ASSERT_TRUE(fit.ok) << fit.why;
  EXPECT_EQ(fit.model, IronFitModel::kHorizontal);
  EXPECT_LT(fit.spread_ratio, 0.05);
  EXPECT_NEAR(fit.heading_coverage_deg, 360.0, 2.0);
  EXPECT_LT((fit.correction.hard_iron_t - b).head<2>().norm(), 20e-9);
  // b_z shows only through tilt; a pitch that follows the heading (the slope) trades it against
  // the x-y gains along a valley flat to a nanotesla, where the fit's weak pull to zero decides.
  EXPECT_LT(std::abs(fit.correction.hard_iron_t.z()), 0.7e-6);  // measured 0.34 uT
  // Up to the scale the trace keeps (W's x-y trace is not K's): K W = s I on x-y.
  const Eigen::Matrix2d KW = (fit.correction.soft_iron_inverse * W).topLeftCorner<2, 2>();
  const double s = KW.trace() / 2.0;
  EXPECT_NEAR(s, 1.0, 0.005);
  EXPECT_LT((KW / s - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff(), 1.5e-3);  // measured 7.4e-4
  EXPECT_LT(fit.rms_after_t, 10e-9);

  // A clean vehicle flying 4 deg nose-down and pitching with the heading over a 4 deg slope:
  // levelled by the accelerometer, the fit finds no iron; the body's z taken as up would fit the
  // trim as ~3 uT of hard iron (sin 4 deg x the 44 uT vertical field) and the slope as soft iron.
  const auto clean = levelTurns(720.0, 4.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 4.0);
  const IronFitResult levelled = fitIronCorrection(clean, IronFitOptions{});
  ASSERT_TRUE(levelled.ok) << levelled.why;
  EXPECT_LT(levelled.correction.hard_iron_t.norm(), 20e-9);
  EXPECT_LT((levelled.correction.soft_iron_inverse - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-4);
  auto blind = clean;
  for (auto& sample : blind) sample.has_specific_force = false;
  const IronFitResult unlevelled = fitIronCorrection(blind, IronFitOptions{});
  ASSERT_TRUE(unlevelled.ok) << unlevelled.why;
  EXPECT_GT(unlevelled.correction.hard_iron_t.norm(), 2e-6);
  EXPECT_GT((unlevelled.correction.soft_iron_inverse - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-3);
}

TEST(IronFit, TooLittleTurningOrTooLittleDataSaysWhatIsMissing) {
  const IronFitResult half =
      fitIronCorrection(levelTurns(150.0, 0.0, Eigen::Matrix3d::Identity(), kHardIron), IronFitOptions{});
  EXPECT_FALSE(half.ok);
  EXPECT_NE(half.why.find("turn the vehicle through at least 270 deg"), std::string::npos) << half.why;
  const IronFitResult few = fitIronCorrection(tumble(10, softIron(), kHardIron, 0.0), IronFitOptions{});
  EXPECT_FALSE(few.ok);
  EXPECT_NE(few.why.find("only 10 blocks"), std::string::npos) << few.why;
}

TEST(IronFitSampler, BlocksAverageTheCoilOutAndGateTheAccelerometer) {
  const Eigen::Matrix3d R_b_m = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  IronFitSampler sampler(1.0, kGravity, 0.3, R_b_m);
  const Eigen::Vector3d dc(1e-5, -2e-5, 4e-5);
  for (int k = 0; k < 3000; ++k) {
    const double t = 100.0 + 1e-3 * k;
    if (k % 5 == 0) {
      ImuSample imu;
      imu.t = t;
      // Second 1: at rest; second 2: accelerating at 1 m/s^2 (no gravity direction); third: at rest.
      imu.accel = Eigen::Vector3d(k >= 1000 && k < 2000 ? 1.0 : 0.0, 0.0, kGravity + (k >= 1000 && k < 2000));
      sampler.feedImu(imu);
    }
    MagSample m;
    m.t = t;
    m.field = dc + Eigen::Vector3d(5e-7, 2e-7, 3e-7) * std::sin(2 * M_PI * 11.0 * (t - 100.0) + 0.3);
    sampler.feedMag(m);
  }
  const auto blocks = sampler.finish();
  ASSERT_EQ(blocks.size(), 3u);
  for (const auto& b : blocks) EXPECT_LT((b.field_t - dc).norm(), 1e-9);  // 11 periods per block
  EXPECT_TRUE(blocks[0].has_specific_force);
  EXPECT_FALSE(blocks[1].has_specific_force);
  EXPECT_TRUE(blocks[2].has_specific_force);
  // The body's up (z) is the mag frame's z as well; its x is the mag frame's -y.
  EXPECT_NEAR(blocks[0].specific_force.z(), kGravity, 1e-9);
}

TEST(MagnetometerOptions, IronCorrectionReadsRoundTripsAndRejectsANonCalibration) {
  const auto o = MagnetometerOptions::fromReader(
      ConfigReader::fromString("iron_correction:\n  hard_iron_t: [3e-6, -3.5e-6, 1.8e-6]\n"
                               "  soft_iron_inverse: [0.96, -0.02, 0.01, -0.02, 1.03, -0.03, 0.01, -0.03, 0.95]\n"));
  EXPECT_DOUBLE_EQ(o.iron_correction.hard_iron_t.y(), -3.5e-6);
  EXPECT_DOUBLE_EQ(o.iron_correction.soft_iron_inverse(1, 2), -0.03);
  EXPECT_FALSE(o.iron_correction.isIdentity());
  const auto again = MagnetometerOptions::fromReader(ConfigReader::fromString(o.toYaml()));
  EXPECT_EQ(again.iron_correction.hard_iron_t, o.iron_correction.hard_iron_t);
  EXPECT_EQ(again.iron_correction.soft_iron_inverse, o.iron_correction.soft_iron_inverse);
  EXPECT_TRUE(MagnetometerOptions{}.iron_correction.isIdentity());

  for (const char* bad : {"iron_correction: {soft_iron_inverse: [1, 0, 0, 0, 1, 0, 0, 0, 0]}\n",
                          "iron_correction: {soft_iron_inverse: [1, 0, 0, 0, 1, 0, 0, 0, -1]}\n",
                          "iron_correction: {soft_iron_inverse: [1, 0, 0, 0, 1, 0]}\n"}) {
    try {
      MagnetometerOptions::fromReader(ConfigReader::fromString(bad, "magnetometer.yaml"));
      ADD_FAILURE() << bad;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("iron_correction.soft_iron_inverse"), std::string::npos) << e.what();
    }
  }
}

TEST(MagneticFrontEnd, TakesTheIronOutBeforeEverything) {
  // The same pass measured by a clean magnetometer and through 5 uT / 5 % of iron: with the
  // correction the front end gives the clean run's signatures and geomagnetic field.
  World world;
  const Streams clean = vims_test::generate(vims_test::circle(Eigen::Vector3d(0, 0, 3.0), 3.0, 0.3), world, 100.0, 30.0,
                                            Eigen::Matrix3d::Identity(), 5e-9, 0.0, 3);
  Streams ironed = clean;
  for (auto& m : ironed.mag) m.field = softIron() * m.field + kHardIron;
  MagnetometerCalibration cal;
  cal.rate_hz = 1000.0;
  cal.noise_std = 5e-9;
  cal.coil_frequency_hz = world.coil_frequency;
  cal.declination_deg = world.declination_deg;
  MagnetometerOptions corrected;
  corrected.iron_correction.hard_iron_t = kHardIron;
  corrected.iron_correction.soft_iron_inverse = softIron().inverse();
  MagneticFrontEnd reference(MagnetometerOptions{}, cal, world.gravity);
  MagneticFrontEnd front_end(corrected, cal, world.gravity);
  MagneticFrontEnd uncorrected(MagnetometerOptions{}, cal, world.gravity);
  const auto a = vims_test::run(reference, clean);
  const auto b = vims_test::run(front_end, ironed);
  const auto c = vims_test::run(uncorrected, ironed);
  ASSERT_EQ(a.signatures.size(), b.signatures.size());
  ASSERT_GT(a.signatures.size(), 50u);
  double worst = 0.0, worst_uncorrected = 0.0;
  for (std::size_t i = 0; i < a.signatures.size(); ++i) {
    const double n = a.signatures[i].amplitude_enu.norm();
    worst = std::max(worst, (b.signatures[i].amplitude_enu - a.signatures[i].amplitude_enu).norm() / n);
    worst_uncorrected =
        std::max(worst_uncorrected, (c.signatures[i].amplitude_enu - a.signatures[i].amplitude_enu).norm() / n);
  }
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(worst_uncorrected, 0.02);  // the soft iron alone moves signatures by percent
  ASSERT_EQ(a.geomagnetic.size(), b.geomagnetic.size());
  for (std::size_t i = 0; i < a.geomagnetic.size(); ++i)
    EXPECT_LT((a.geomagnetic[i].field_b - b.geomagnetic[i].field_b).norm(), 1e-12) << i;
}
