/// Visual-inertial initialisation (SfM + gyroscope bias + linear alignment) on synthetic data:
/// a downward camera over a seabed with relief, features projected with pixel noise, and the
/// ideal IMU of an analytic trajectory with a gyroscope bias. With enough acceleration the
/// metric scale, gravity (roll/pitch), velocities and the gyroscope bias are recovered; with
/// (almost) constant velocity the initialiser must report insufficient excitation instead of a
/// scale.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <random>
#include <vector>

#include "analytic_trajectory.h"
#include "vims_estimator/initialization/visual_inertial_initializer.h"

namespace {

using vims::test::AnalyticTrajectory;

constexpr double kFocal = 460.0;
constexpr double kPixelNoise = 0.5;

vims::ImuNoiseParams noiseParams() {
  vims::ImuNoiseParams n;
  n.gyro_noise_density = 1e-3;
  n.accel_noise_density = 1e-2;
  n.gyro_random_walk = 1e-5;
  n.accel_random_walk = 1e-4;
  return n;
}

/// Downward optical camera on an FLU body: z_c = -z_b, x_c = -y_b, y_c = -x_b; 10 cm ahead.
Eigen::Isometry3d cameraExtrinsic() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d R;
  R.col(0) = Eigen::Vector3d(0, -1, 0);
  R.col(1) = Eigen::Vector3d(-1, 0, 0);
  R.col(2) = Eigen::Vector3d(0, 0, -1);
  T.linear() = R;
  T.translation() = Eigen::Vector3d(0.1, 0.02, -0.05);
  return T;
}

struct Scenario {
  std::vector<vims::InitFrame> frames;
  std::vector<double> times;
  std::vector<Eigen::Vector3d> points;  ///< world points, indexed by feature id
};

/// Frames every `frame_dt` over the trajectory; seabed points around z = 0 (+-0.4 m relief)
/// covering the footprint; IMU at 200 Hz with a constant gyroscope bias.
Scenario makeScenario(const AnalyticTrajectory& traj, int n_frames, double frame_dt, const Eigen::Vector3d& gyro_bias,
                      unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-4.0, 6.0), uy(-6.0, 2.0), uz(-0.4, 0.4);
  std::normal_distribution<double> pixel(0.0, kPixelNoise / kFocal);
  std::vector<Eigen::Vector3d> points(3000);
  for (auto& p : points) p = Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
  const Eigen::Isometry3d T_b_c = cameraExtrinsic();
  Scenario s;
  s.points = points;
  for (int k = 0; k < n_frames; ++k) {
    const double t = k * frame_dt;
    vims::InitFrame f;
    f.t = t;
    const Eigen::Isometry3d T_c_w = (traj.pose(t) * T_b_c).inverse();
    for (std::size_t id = 0; id < points.size(); ++id) {
      const Eigen::Vector3d pc = T_c_w * points[id];
      if (pc.z() < 0.5) continue;
      const Eigen::Vector2d uv = pc.head<2>() / pc.z();
      if (std::abs(uv.x()) > 0.7 || std::abs(uv.y()) > 0.55) continue;
      f.observations[id] = uv + Eigen::Vector2d(pixel(rng), pixel(rng));
    }
    if (k > 0) {
      const double t0 = (k - 1) * frame_dt;
      const int steps = static_cast<int>(std::lround(frame_dt * 200.0));
      auto sample = [&](int i) {
        vims::ImuSample x = traj.imu(t0 + frame_dt * i / steps);
        x.gyro += gyro_bias;
        return x;
      };
      auto pre = std::make_shared<vims::ImuPreintegration>(sample(0), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                                                           noiseParams());
      for (int i = 1; i <= steps; ++i) pre->addSample(sample(i));
      f.preintegration = pre;
    }
    s.frames.push_back(f);
    s.times.push_back(t);
  }
  return s;
}

vims::VisualInertialInitializer makeInitializer(const AnalyticTrajectory& traj) {
  return vims::VisualInertialInitializer(cameraExtrinsic(), traj.gravity, kFocal, vims::VisualInertialInitOptions());
}

}  // namespace

TEST(VisualInertialInit, RecoversMetricScaleGravityVelocityAndGyroBias) {
  const AnalyticTrajectory traj;  // accelerations of 0.5-1 m/s^2, roll/pitch/yaw oscillations
  const Eigen::Vector3d bg_true(0.01, -0.015, 0.02);
  Scenario s = makeScenario(traj, 11, 0.5, bg_true, 1);
  const vims::VisualInertialInitResult r = makeInitializer(traj).initialize(s.frames);
  ASSERT_TRUE(r.ok()) << vims::visualInertialInitStatusName(r.status) << ": " << r.message;
  std::cout << r.message << "\n";
  EXPECT_LT((r.gyro_bias - bg_true).norm(), 2e-3);
  ASSERT_EQ(r.T_w_b.size(), s.frames.size());

  // The result's frame: gravity along -z, origin and yaw of the first body pose.
  const Eigen::Isometry3d T_gt0 = traj.pose(s.times[0]);
  const Eigen::Matrix3d R0 = T_gt0.linear();
  const Eigen::Matrix3d R_align =
      Eigen::AngleAxisd(-std::atan2(R0(1, 0), R0(0, 0)), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  double max_distance = 0.0, max_position_error = 0.0, max_velocity_error = 0.0, max_rotation_error = 0.0;
  double path_est = 0.0, path_true = 0.0;
  for (std::size_t k = 0; k < s.frames.size(); ++k) {
    const Eigen::Isometry3d T_gt = traj.pose(s.times[k]);
    const Eigen::Vector3d p_expected = R_align * (T_gt.translation() - T_gt0.translation());
    max_distance = std::max(max_distance, p_expected.norm());
    max_position_error = std::max(max_position_error, (r.T_w_b[k].translation() - p_expected).norm());
    max_velocity_error = std::max(max_velocity_error, (r.v_w_b[k] - R_align * traj.velocity(s.times[k])).norm());
    if (k > 0) {
      path_est += (r.T_w_b[k].translation() - r.T_w_b[k - 1].translation()).norm();
      path_true += (T_gt.translation() - traj.pose(s.times[k - 1]).translation()).norm();
    }
    const Eigen::Matrix3d dR = (R_align * T_gt.linear()).transpose() * r.T_w_b[k].linear();
    max_rotation_error = std::max(max_rotation_error, Eigen::AngleAxisd(dR).angle());
  }
  ASSERT_GT(max_distance, 1.0);
  // Metric scale within 1 % (path length of the window); positions within 2 % of the distance
  // (scale and attitude noise of the SfM); gravity direction (hence roll and pitch) within
  // 0.5 deg; velocities within 3 cm/s. Noise-free data give all of them to < 1e-6.
  std::cout << "path length estimated " << path_est << " m, true " << path_true << " m\n";
  EXPECT_NEAR(path_est / path_true, 1.0, 0.01);
  EXPECT_LT(max_position_error, 0.02 * max_distance) << "max distance " << max_distance;
  EXPECT_LT(max_rotation_error, 0.5 * M_PI / 180.0);
  EXPECT_LT(max_velocity_error, 0.03);
  EXPECT_LT(r.scale_relative_std, 0.02);
  EXPECT_LT(r.accel_bias.norm(), 0.05) << "the simulated accelerometer has no bias";
  // Points: median error below 1.5 % of the ~3 m depth.
  ASSERT_GT(r.points_w.size(), 100u);
  std::vector<double> point_errors;
  for (const auto& [id, p] : r.points_w) {
    point_errors.push_back((R_align.transpose() * p + T_gt0.translation() - s.points[id]).norm());
  }
  std::nth_element(point_errors.begin(), point_errors.begin() + point_errors.size() / 2, point_errors.end());
  EXPECT_LT(point_errors[point_errors.size() / 2], 0.045);
  // The preintegrations were repropagated at the estimated gyroscope bias.
  EXPECT_LT((s.frames[1].preintegration->linearizedGyroBias() - bg_true).norm(), 2e-3);
}

TEST(VisualInertialInit, ConstantVelocityReportsInsufficientExcitation) {
  // Constant velocity (and a slow constant turn): the IMU cannot tell the speed, so the scale is
  // unobservable. The initialiser must say so rather than return a scale.
  const AnalyticTrajectory traj =
      AnalyticTrajectory::constantVelocity(Eigen::Vector3d(1.0, -2.0, 3.0), Eigen::Vector3d(0.4, 0.1, 0.0), 0.4, 0.1);
  Scenario s = makeScenario(traj, 11, 0.3, Eigen::Vector3d::Zero(), 2);
  const vims::VisualInertialInitResult r = makeInitializer(traj).initialize(s.frames);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.status, vims::VisualInertialInitStatus::kInsufficientExcitation) << r.message;
  EXPECT_TRUE(r.T_w_b.empty());
}

TEST(VisualInertialInit, SlowAuvLikeAccelerationReportsInsufficientExcitation) {
  // Tank-like motion: 0.3 m/s with accelerations of a few mm/s^2, far below what separates the
  // scale from an accelerometer bias of 0.05 m/s^2 over 3 s.
  AnalyticTrajectory traj =
      AnalyticTrajectory::constantVelocity(Eigen::Vector3d(1.0, -2.0, 3.0), Eigen::Vector3d(0.3, 0.0, 0.0), 0.4, 0.05);
  traj.amplitude = Eigen::Vector3d(0.02, 0.02, 0.0);
  traj.omega = Eigen::Vector3d(0.4, 0.3, 1.0);
  Scenario s = makeScenario(traj, 11, 0.3, Eigen::Vector3d::Zero(), 3);
  const vims::VisualInertialInitResult r = makeInitializer(traj).initialize(s.frames);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.status, vims::VisualInertialInitStatus::kInsufficientExcitation) << r.message;
}

TEST(VisualInertialInit, NoParallaxAndTooFewFramesAreReported) {
  const AnalyticTrajectory still =
      AnalyticTrajectory::constantVelocity(Eigen::Vector3d(1.0, -2.0, 3.0), Eigen::Vector3d::Zero(), 0.4, 0.0);
  Scenario s = makeScenario(still, 11, 0.3, Eigen::Vector3d::Zero(), 4);
  vims::VisualInertialInitResult r = makeInitializer(still).initialize(s.frames);
  EXPECT_EQ(r.status, vims::VisualInertialInitStatus::kNoRelativePose) << r.message;

  const AnalyticTrajectory traj;
  Scenario few = makeScenario(traj, 3, 0.3, Eigen::Vector3d::Zero(), 5);
  r = makeInitializer(traj).initialize(few.frames);
  EXPECT_EQ(r.status, vims::VisualInertialInitStatus::kTooFewFrames);
  Scenario more = makeScenario(traj, 6, 0.3, Eigen::Vector3d::Zero(), 6);
  more.frames[3].preintegration.reset();
  r = makeInitializer(traj).initialize(more.frames);
  EXPECT_EQ(r.status, vims::VisualInertialInitStatus::kTooFewFrames) << "a frame without IMU";
}

TEST(VisualInertialInit, OptionsRejectBadValuesByKey) {
  const auto reader = vims::ConfigReader::fromString("window_frames: 2\n");
  try {
    vims::VisualInertialInitOptions::fromReader(reader);
    FAIL() << "window_frames: 2 accepted";
  } catch (const vims::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("window_frames"), std::string::npos);
  }
  EXPECT_THROW(vims::VisualInertialInitOptions::fromReader(vims::ConfigReader::fromString("unknown_key: 1\n")),
               vims::ConfigError);
  const auto defaults = vims::VisualInertialInitOptions::fromReader(vims::ConfigReader::fromString("{}"));
  EXPECT_EQ(defaults.window_frames, vims::VisualInertialInitOptions().window_frames);
}
