// Noise statistics of the IMU, the sonar altimeter and their geometry.
#include <gtest/gtest.h>

#include <cmath>

#include "vims_sim/sensor_models.h"

using namespace vims::sim;

TEST(Imu, Mti630NoiseFigures) {
  const ImuNoiseParams p = ImuNoiseParams::mti630();
  EXPECT_NEAR(p.gyro_noise_density, 0.007 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(p.accel_noise_density, 60e-6 * 9.81, 1e-12);
  EXPECT_GT(p.gyro_random_walk, 1e-6);
  EXPECT_LT(p.gyro_random_walk, 1e-5);
  EXPECT_GT(p.accel_random_walk, 1e-6);
  EXPECT_LT(p.accel_random_walk, 1e-4);
  EXPECT_EQ(p.rate_hz, 200.0);
}

TEST(Imu, WhiteNoiseAndBiasMatchTheParameters) {
  ImuNoiseParams p = ImuNoiseParams::mti630();
  p.gyro_random_walk = 0.0;
  p.accel_random_walk = 0.0;
  const Eigen::Vector3d gyro_bias(1e-3, -2e-3, 5e-4), accel_bias(0.01, -0.02, 0.015);
  ImuSimulator imu(p, gyro_bias, accel_bias, 7);
  TrajectoryState rest;
  rest.q_w_b = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  const Eigen::Vector3d f_ideal = ImuSimulator::idealSpecificForce(rest, p.gravity);
  EXPECT_LT((f_ideal - Eigen::Vector3d(0, 0, 9.81)).norm(), 1e-12);
  const int n = 100000;
  Eigen::Vector3d gyro_sum = Eigen::Vector3d::Zero(), accel_sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_sq = Eigen::Vector3d::Zero(), accel_sq = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    const ImuMeasurement m = imu.measure(rest);
    const Eigen::Vector3d eg = m.gyro - gyro_bias, ea = m.accel - f_ideal - accel_bias;
    gyro_sum += eg;
    accel_sum += ea;
    gyro_sq += eg.cwiseProduct(eg);
    accel_sq += ea.cwiseProduct(ea);
  }
  const double gyro_std = p.gyro_noise_density * std::sqrt(p.rate_hz);
  const double accel_std = p.accel_noise_density * std::sqrt(p.rate_hz);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(std::sqrt(gyro_sq[i] / n), gyro_std, 0.02 * gyro_std);
    EXPECT_NEAR(std::sqrt(accel_sq[i] / n), accel_std, 0.02 * accel_std);
    EXPECT_NEAR(gyro_sum[i] / n, 0.0, 5.0 * gyro_std / std::sqrt(n));
    EXPECT_NEAR(accel_sum[i] / n, 0.0, 5.0 * accel_std / std::sqrt(n));
  }
}

TEST(Imu, BiasRandomWalkGrowsWithTheSquareRootOfTime) {
  ImuNoiseParams p = ImuNoiseParams::mti630();
  p.gyro_noise_density = 0.0;
  p.accel_noise_density = 0.0;
  const int runs = 300, steps = 2000;  // 10 s each
  double gyro_sq = 0.0, accel_sq = 0.0;
  TrajectoryState rest;
  for (int r = 0; r < runs; ++r) {
    ImuSimulator imu(p, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 1000 + r);
    ImuMeasurement m;
    for (int k = 0; k <= steps; ++k) m = imu.measure(rest);
    gyro_sq += m.gyro_bias.squaredNorm();
    accel_sq += m.accel_bias.squaredNorm();
  }
  const double T = steps / p.rate_hz;
  EXPECT_NEAR(std::sqrt(gyro_sq / (3 * runs)), p.gyro_random_walk * std::sqrt(T),
              0.1 * p.gyro_random_walk * std::sqrt(T));
  EXPECT_NEAR(std::sqrt(accel_sq / (3 * runs)), p.accel_random_walk * std::sqrt(T),
              0.1 * p.accel_random_walk * std::sqrt(T));
}

TEST(Sonar, SlantRangeAlongATiltedBeam) {
  Eigen::Isometry3d T_b_s = Eigen::Isometry3d::Identity();
  const double tilt = 0.1;
  T_b_s.linear() =
      (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  T_b_s.translation() = Eigen::Vector3d(0.1, 0.0, -0.2);
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.translation() = Eigen::Vector3d(3.0, 4.0, 3.2);
  const double r = SonarSimulator::trueRange(T_w_b, T_b_s);
  EXPECT_NEAR(r, 3.0 / std::cos(tilt), 1e-12);
  // The point T_b_s * [0, 0, r] lies on the seabed.
  EXPECT_NEAR((T_w_b * T_b_s * Eigen::Vector3d(0, 0, r)).z(), 0.0, 1e-12);
  // A beam pointing up never hits the seabed.
  EXPECT_TRUE(std::isinf(SonarSimulator::trueRange(T_w_b, Eigen::Isometry3d::Identity())));
}

TEST(Sonar, NoiseOutliersAndDropoutsHaveTheConfiguredRates) {
  SonarParams p;
  Eigen::Isometry3d T_b_s = Eigen::Isometry3d::Identity();
  T_b_s.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.translation().z() = 3.0;
  SonarSimulator sonar(p, T_b_s, 3);
  const int n = 100000;
  int outliers = 0, dropouts = 0, good = 0;
  double sq = 0.0;
  for (int i = 0; i < n; ++i) {
    const SonarReading r = sonar.measure(T_w_b);
    ASSERT_NEAR(r.true_range, 3.0, 1e-12);
    if (r.kind == SonarReading::Kind::kDropout) {
      ASSERT_TRUE(std::isinf(r.range) && r.range > 0);
      ++dropouts;
    } else if (r.kind == SonarReading::Kind::kOutlier) {
      ASSERT_GT(r.range, 1.3 * 3.0 - 0.2);
      ASSERT_LT(r.range, 2.0 * 3.0 + 0.2);
      ++outliers;
    } else {
      sq += (r.range - 3.0) * (r.range - 3.0);
      ++good;
    }
  }
  EXPECT_NEAR(outliers / double(n), 0.03, 0.003);
  EXPECT_NEAR(dropouts / double(n), 0.01, 0.0015);
  EXPECT_NEAR(std::sqrt(sq / good), 0.02, 0.0006);
}
