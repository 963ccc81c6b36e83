#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/vehicle_field.h"

using namespace vims;

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kNanoTesla = 1e-9;

/// A lawnmower in the odometry frame: legs of `leg_s` seconds at 0.2-0.45 m/s (the speed changes
/// from leg to leg), 180 deg turns of 10 s between them, slowing down into each turn.
struct Lawnmower {
  double leg_s = 40.0;
  double turn_s = 10.0;

  double yaw(double t) const {
    const double period = leg_s + turn_s;
    const int leg = static_cast<int>(t / period);
    const double in_period = t - leg * period;
    const double base = (leg % 2 == 0) ? 0.0 : M_PI;
    return in_period < leg_s ? base : base + M_PI * (in_period - leg_s) / turn_s;
  }
  double speed(double t) const {
    const double period = leg_s + turn_s;
    const int leg = static_cast<int>(t / period);
    const double in_period = t - leg * period;
    const double cruise = 0.2 + 0.05 * (leg % 6);
    if (in_period < leg_s - 5.0) return cruise;
    if (in_period < leg_s) return cruise - (cruise - 0.1) * (in_period - (leg_s - 5.0)) / 5.0;  // slowing down
    return 0.1 + (cruise - 0.1) * (in_period - leg_s) / turn_s;                                 // speeding up
  }
  ForwardMotion motion(double t) const {
    const double h = 1e-3;
    return ForwardMotion{speed(t), (speed(t + h) - speed(t - h)) / (2.0 * h)};
  }
};

/// The vehicle's true field: one current's direction, following a thrust of drag and inertia
/// (`scale`: of the thrust-following part).
Eigen::Vector3d thrusterField(const ForwardMotion& m, double scale = 1.0) {
  const Eigen::Vector3d direction = Eigen::Vector3d(0.9, -0.3, 0.3).normalized();
  const double thrust = m.speed_mps * std::abs(m.speed_mps) + 3.0 * m.accel_mps2;
  return Eigen::Vector3d(0.4e-6, -0.2e-6, 0.1e-6) + scale * direction * 12e-6 * thrust;  // 3 uT at 0.5 m/s
}

struct Drive {
  Lawnmower path;
  double duration_s = 400.0;
  double dt = 0.4;                 ///< keyframe spacing
  double noise_tesla = 30e-9;      ///< per axis, white
  double vio_yaw_error_rad = 0.0;  ///< constant heading error of the VIO's attitude
  bool thrusters = true;
  /// An extra field in the odometry frame over [disturbance_from_s, disturbance_to_s).
  Eigen::Vector3d disturbance = Eigen::Vector3d::Zero();
  double disturbance_from_s = 0.0, disturbance_to_s = 0.0;
  double growth_per_s = 0.0;  ///< the thrust-following part is 1 + growth_per_s t times its size
  uint32_t seed = 1;

  /// Feeds the estimator; returns the RMS error of the field it would take out, over the last
  /// half of the drive [T].
  double run(VehicleFieldEstimator& estimator) const {
    const Eigen::Vector3d F_odom(2e-6, 33e-6, -36e-6);
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, noise_tesla);
    double sum = 0.0;
    int n = 0;
    for (double t = 0.0; t < duration_s; t += dt) {
      const double yaw = path.yaw(t);
      const Eigen::Matrix3d R_true = rotationFromYawPitchRoll(yaw, 0.02 * std::sin(0.1 * t), 0.01);
      const ForwardMotion m = path.motion(t);
      Eigen::Vector3d F = F_odom;
      if (t >= disturbance_from_s && t < disturbance_to_s) F += disturbance;
      Eigen::Vector3d field_b = R_true.transpose() * F + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      const double scale = 1.0 + growth_per_s * t;
      if (thrusters) field_b += thrusterField(m, scale);
      const Eigen::Matrix3d R_vio = rotationFromYawPitchRoll(yaw + vio_yaw_error_rad, 0.02 * std::sin(0.1 * t), 0.01);
      estimator.add(0, t, R_vio, field_b, m);
      if (t > duration_s / 2) {
        const Eigen::Vector3d truth = thrusters ? thrusterField(m, scale) : Eigen::Vector3d::Zero();
        // Only the horizontal error matters for the heading (a vertical offset is the site's).
        const Eigen::Vector3d error = R_true * (estimator.vehicleField(m) - truth);
        sum += error.head<2>().squaredNorm();
        ++n;
      }
    }
    return std::sqrt(sum / std::max(1, n));
  }
};

}  // namespace

TEST(ForwardMotion, TheParabolaThroughKeyframesGivesSpeedAndAcceleration) {
  // Moving along the body's x axis (heading 60 deg in the odometry frame) with v = 0.3 + 0.05 t.
  const Eigen::Matrix3d R = rotationFromYawPitchRoll(60.0 * kDeg, 0.0, 0.0);
  auto at = [&](double t) {
    return TimedPosition{t, Eigen::Vector3d(1, 2, -3) + R.col(0) * (0.3 * t + 0.025 * t * t)};
  };
  const std::vector<TimedPosition> around = {at(-0.8), at(-0.4), at(0.0), at(0.45), at(0.8)};
  const std::optional<ForwardMotion> m = forwardMotion(around, 0.0, R);
  ASSERT_TRUE(m.has_value());
  EXPECT_NEAR(m->speed_mps, 0.3, 1e-9);
  EXPECT_NEAR(m->accel_mps2, 0.05, 1e-9);
  // Only keyframes before it (the newest keyframe): the same parabola.
  const std::optional<ForwardMotion> newest = forwardMotion({at(-0.8), at(-0.4), at(0.0)}, 0.0, R);
  ASSERT_TRUE(newest.has_value());
  EXPECT_NEAR(newest->speed_mps, 0.3, 1e-9);
  // Backwards is negative; a sideways motion is not forward.
  EXPECT_NEAR(forwardMotion(around, 0.0, rotationFromYawPitchRoll(240.0 * kDeg, 0.0, 0.0))->speed_mps, -0.3, 1e-9);
  EXPECT_NEAR(forwardMotion(around, 0.0, rotationFromYawPitchRoll(150.0 * kDeg, 0.0, 0.0))->speed_mps, 0.0, 1e-9);
  // Two distinct times do not make a parabola.
  EXPECT_FALSE(forwardMotion({at(0.0), at(0.4)}, 0.4, R).has_value());
  EXPECT_FALSE(forwardMotion({at(0.0), at(0.4), at(0.4)}, 0.4, R).has_value());
}

TEST(VehicleField, FindsAThrustFollowingFieldAndTakesItOut) {
  VehicleFieldEstimator estimator{VehicleFieldOptions{}};
  const double error = Drive{}.run(estimator);
  EXPECT_TRUE(estimator.applied());
  EXPECT_GT(estimator.explainedFraction(), 0.99);  // measured 0.99998
  // Measured 4.1 nT of horizontal error (of 1.5 uT at cruise): a heading error below 0.01 deg.
  EXPECT_LT(error, 10e-9) << error / kNanoTesla << " nT";
  // The residual is the noise (30 nT per axis).
  EXPECT_NEAR(estimator.residualRms(), 30e-9, 6e-9);
}

TEST(VehicleField, SurvivesAVioHeadingErrorAndASecondSession) {
  // A VIO whose yaw is 3 deg off: the session's field absorbs it (it is the same for every sample).
  Drive drive;
  drive.vio_yaw_error_rad = 3.0 * kDeg;
  VehicleFieldEstimator estimator{VehicleFieldOptions{}};
  EXPECT_LT(drive.run(estimator), 10e-9);  // measured 4.1 nT
  // A second session in a frame turned by 70 deg: the vehicle's field carries over.
  VehicleFieldEstimator two_sessions{VehicleFieldOptions{}};
  Drive first;
  first.duration_s = 200.0;
  first.run(two_sessions);
  const Eigen::Matrix3d turned = rotationFromYawPitchRoll(70.0 * kDeg, 0.0, 0.0);
  const Eigen::Vector3d F_odom(2e-6, 33e-6, -36e-6);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 30e-9);
  for (double t = 200.0; t < 400.0; t += 0.4) {
    const Eigen::Matrix3d R_true = rotationFromYawPitchRoll(first.path.yaw(t), 0.0, 0.01);
    const ForwardMotion m = first.path.motion(t);
    const Eigen::Vector3d field_b =
        R_true.transpose() * F_odom + thrusterField(m) + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    two_sessions.add(1, t, turned * R_true, field_b, m);
  }
  EXPECT_TRUE(two_sessions.applied());
  const ForwardMotion cruise{0.35, 0.0};
  const Eigen::Vector3d error = two_sessions.vehicleField(cruise) - thrusterField(cruise);
  EXPECT_LT(error.head<2>().norm(), 10e-9) << error.transpose() / kNanoTesla;  // measured 2.5 nT
}

TEST(VehicleField, ACleanVehicleGetsNoCorrection) {
  Drive drive;
  drive.thrusters = false;
  drive.vio_yaw_error_rad = 0.1 * kDeg;
  VehicleFieldEstimator estimator{VehicleFieldOptions{}};
  drive.run(estimator);
  EXPECT_FALSE(estimator.applied());
  EXPECT_LT(estimator.explainedFraction(), 0.45);  // measured 0.0000: noise (applied from 0.9)
  EXPECT_EQ(estimator.vehicleField(ForwardMotion{0.4, 0.01}), Eigen::Vector3d::Zero());
}

TEST(VehicleField, ADisturbedSiteIsNotTakenForTheVehicle) {
  // 2 uT across the field for 60 s of a clean vehicle's drive (steel on the seabed): it is not
  // the vehicle's (it does not follow the motion), so the fit explains little of it.
  Drive drive;
  drive.thrusters = false;
  drive.disturbance = Eigen::Vector3d(2e-6, 0.0, 0.0);
  drive.disturbance_from_s = 150.0;
  drive.disturbance_to_s = 210.0;
  VehicleFieldEstimator estimator{VehicleFieldOptions{}};
  drive.run(estimator);
  EXPECT_FALSE(estimator.applied());
  EXPECT_LT(estimator.explainedFraction(), 0.2);  // measured 0.10
}

TEST(VehicleField, FollowsAFieldThatChangesWithItsMemory) {
  // The thrust-following part grows by half over 1000 s (a motor warming, a battery swapped):
  // a 200 s memory follows it better than no forgetting.
  auto errorAtTheEnd = [](double memory_s) {
    VehicleFieldOptions options;
    options.memory_s = memory_s;
    VehicleFieldEstimator estimator(options);
    Drive drive;
    drive.duration_s = 1000.0;
    drive.growth_per_s = 0.5 / 1000.0;
    drive.run(estimator);
    const ForwardMotion cruise{0.35, 0.0};
    EXPECT_TRUE(estimator.applied());
    return (estimator.vehicleField(cruise) - thrusterField(cruise, 1.5)).head<2>().norm();
  };
  const double short_memory = errorAtTheEnd(200.0);
  const double no_forgetting = errorAtTheEnd(1e7);
  EXPECT_LT(short_memory, 650e-9) << short_memory / kNanoTesla << " nT";                // measured 324 nT (of 2.3 uT)
  EXPECT_LT(short_memory, 0.8 * no_forgetting) << no_forgetting / kNanoTesla << " nT";  // measured 803 nT
}

TEST(VehicleField, IgnoresNonFiniteInputAndCanBeDisabled) {
  VehicleFieldEstimator estimator{VehicleFieldOptions{}};
  const double nan = std::nan("");
  estimator.add(0, 0.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d(nan, 0, 0), ForwardMotion{});
  estimator.add(0, nan, Eigen::Matrix3d::Identity(), Eigen::Vector3d(1e-6, 0, 0), ForwardMotion{});
  estimator.add(0, 0.0, Eigen::Matrix3d::Identity(), Eigen::Vector3d(1e-6, 0, 0), ForwardMotion{nan, 0.0});
  EXPECT_EQ(estimator.numSamples(), 0u);
  EXPECT_TRUE(std::isnan(estimator.residualRms()));

  VehicleFieldOptions off;
  off.enabled = false;
  VehicleFieldEstimator disabled(off);
  Drive{}.run(disabled);
  EXPECT_EQ(disabled.numSamples(), 0u);
  EXPECT_FALSE(disabled.applied());
}
