// Every analytic Jacobian (IMU, reprojection with direct depth and td, sonar depth, pose prior,
// relative pose, marginalisation prior) against central differences in the blocks' tangent
// spaces (PoseManifold for poses), at random non-trivial states, several seeds each.
#include <gtest/gtest.h>

#include <random>

#include "analytic_trajectory.h"
#include "test_utils.h"
#include "vims_estimator/factors/imu_factor.h"
#include "vims_estimator/factors/marginalization_factor.h"
#include "vims_estimator/factors/pose_prior_factor.h"
#include "vims_estimator/factors/pressure_depth_factor.h"
#include "vims_estimator/factors/relative_pose_factor.h"
#include "vims_estimator/factors/reprojection_factor.h"
#include "vims_estimator/factors/sonar_depth_factor.h"
#include "vims_estimator/factors/window_hit_factor.h"

namespace vims {
namespace {

using test::poseBlock;
using test::randomRotation;
using test::randomVector;
constexpr BlockManifold kPose = BlockManifold::kPose;
constexpr BlockManifold kEuclid = BlockManifold::kEuclidean;

// Central-difference step and tolerance: truncation ~h^2 and rounding ~1e-16/h relative, both far
// below 1e-6; a wrong sign, frame or missing term gives O(1e-2..1) relative errors.
constexpr double kStep = 1e-6;
constexpr double kTol = 1e-6;
constexpr unsigned kSeeds[] = {1, 2, 3, 4, 5, 6};

std::vector<double> speedBiasBlock(const Eigen::Vector3d& v, const Eigen::Vector3d& ba, const Eigen::Vector3d& bg) {
  std::vector<double> b(9);
  Eigen::Map<Eigen::Matrix<double, 9, 1>>(b.data()) << v, ba, bg;
  return b;
}

/// A pose rotated by up to `max_angle` [rad] and placed within `extent` [m] per axis of the origin
/// (the rotation is drawn first).
Eigen::Isometry3d randomPose(std::mt19937& rng, double max_angle, double extent) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = randomRotation(rng, max_angle).toRotationMatrix();
  T.translation() = randomVector(rng, extent);
  return T;
}

/// A sensor looking down from an FLU body (its z = -body z), rotated by up to `max_angle` and
/// offset by up to `extent` from there (a camera or the sonar's mount).
Eigen::Isometry3d randomDownLookingPose(std::mt19937& rng, double max_angle, double extent) {
  Eigen::Isometry3d T = randomPose(rng, max_angle, extent);
  T.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix() * T.linear();
  return T;
}

/// A camera looking down from an FLU body (optical z = -body z), slightly rotated and offset.
Eigen::Isometry3d downLookingCamera(std::mt19937& rng) { return randomDownLookingPose(rng, 0.2, 0.2); }

FeatureObservation randomObservation(std::mt19937& rng) {
  FeatureObservation o;
  o.uv = randomVector(rng, 0.4).head<2>();
  o.velocity = randomVector(rng, 0.3).head<2>();
  o.td_frame = randomVector(rng, 0.01).x();
  return o;
}

TEST(FactorJacobians, ImuFactor) {
  const test::AnalyticTrajectory traj;
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(seed);
    const double ti = 0.2 + 0.1 * seed, T = seed % 2 ? 0.1 : 0.6;
    const Eigen::Vector3d ba_true = randomVector(rng, 0.1), bg_true = randomVector(rng, 0.01);
    std::vector<ImuSample> samples;
    for (int k = 0; k <= static_cast<int>(std::lround(T * 200)); ++k) {
      ImuSample s = traj.imu(ti + k / 200.0);
      s.accel += ba_true;
      s.gyro += bg_true;
      samples.push_back(s);
    }
    ImuNoiseParams noise;
    noise.gyro_noise_density = 1.7e-4;
    noise.accel_noise_density = 2e-3;
    noise.gyro_random_walk = 2e-5;
    noise.accel_random_walk = 3e-3;
    // Linearised away from the state biases so the bias-correction terms (incl. Jr(phi)) matter.
    const Eigen::Vector3d ba_lin = ba_true + randomVector(rng, 0.05), bg_lin = bg_true + randomVector(rng, 0.02);
    auto pre = std::make_shared<ImuPreintegration>(ImuPreintegration::fromSamples(samples, ba_lin, bg_lin, noise));
    const ImuFactor factor(pre, traj.gravityWorld());

    const double tj = samples.back().t;
    std::vector<std::vector<double>> params = {
        poseBlock(traj.position(ti) + randomVector(rng, 0.3), traj.rotation(ti) * randomRotation(rng, 0.3)),
        speedBiasBlock(traj.velocity(ti) + randomVector(rng, 0.2), ba_true + randomVector(rng, 0.05),
                       bg_true + randomVector(rng, 0.02)),
        poseBlock(traj.position(tj) + randomVector(rng, 0.3), traj.rotation(tj) * randomRotation(rng, 0.3)),
        speedBiasBlock(traj.velocity(tj) + randomVector(rng, 0.2), ba_true + randomVector(rng, 0.05),
                       bg_true + randomVector(rng, 0.02))};
    // The residual is far from zero: the check runs at a non-trivial point.
    EXPECT_GT(test::evaluateResidual(factor, params).norm(), 10.0);
    worst = std::max(worst, test::checkJacobians(factor, params, {kPose, kEuclid, kPose, kEuclid}, kStep, kTol,
                                                 "imu seed " + std::to_string(seed)));
  }
  RecordProperty("worst_relative_error", test::sci(worst));
}

// The IMU residual is zero at the true states with the true biases (model consistency, not only
// derivative consistency).
TEST(FactorJacobians, ImuResidualVanishesAtTruth) {
  const test::AnalyticTrajectory traj;
  std::vector<ImuSample> samples;
  for (int k = 0; k <= 100; ++k) samples.push_back(traj.imu(0.5 + k / 200.0));
  ImuNoiseParams noise;
  noise.gyro_noise_density = noise.accel_noise_density = noise.gyro_random_walk = noise.accel_random_walk = 1e-3;
  const ImuPreintegration pre =
      ImuPreintegration::fromSamples(samples, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), noise);
  NavState xi, xj;
  xi.p_l_b = traj.position(0.5);
  xi.q_l_b = traj.rotation(0.5);
  xi.v_l_b = traj.velocity(0.5);
  xj.p_l_b = traj.position(1.0);
  xj.q_l_b = traj.rotation(1.0);
  xj.v_l_b = traj.velocity(1.0);
  EXPECT_LT(imuResidual(pre, traj.gravityWorld(), xi, xj).norm(), 1e-5);
}

TEST(FactorJacobians, ReprojectionFactorWithDirectDepthAndTimeOffset) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(100 + seed);
    const Eigen::Isometry3d T_b_c = downLookingCamera(rng);
    Eigen::Isometry3d T_l_bi = Eigen::Isometry3d::Identity();
    T_l_bi.linear() = randomRotation(rng, 0.3).toRotationMatrix();
    T_l_bi.translation() = randomVector(rng, 2.0) + Eigen::Vector3d(0, 0, 4.0);
    Eigen::Isometry3d T_l_bk = T_l_bi;
    T_l_bk.linear() = T_l_bi.linear() * randomRotation(rng, 0.2).toRotationMatrix();
    T_l_bk.translation() += randomVector(rng, 0.6);

    const FeatureObservation anchor = randomObservation(rng);
    FeatureObservation target = randomObservation(rng);
    const double lambda = 3.0 + randomVector(rng, 1.0).x();
    const double td = randomVector(rng, 0.02).x();
    // Target observation near the true projection (non-zero residual).
    double z = 0.0;
    const Eigen::Vector2d r0 = reprojectionResidual(anchor, target, T_l_bi, T_l_bk, T_b_c, lambda, td, nullptr, &z);
    ASSERT_GT(z, 1.0);
    target.uv -= r0 - randomVector(rng, 0.01).head<2>();

    const ReprojectionFactor factor(anchor, target, Eigen::Vector2d(460.0 / 1.5, 455.0 / 1.5).asDiagonal());
    std::vector<std::vector<double>> params = {poseBlock(T_l_bi), poseBlock(T_l_bk), poseBlock(T_b_c), {lambda}, {td}};
    EXPECT_GT(test::evaluateResidual(factor, params).norm(), 0.5);
    worst = std::max(worst, test::checkJacobians(factor, params, {kPose, kPose, kPose, kEuclid, kEuclid}, kStep, kTol,
                                                 "reprojection seed " + std::to_string(seed)));
  }
  RecordProperty("worst_relative_error", test::sci(worst));
}

// The td sign convention is the physical one: images stamped td late (t_stamp = t_exposure + td),
// states placed at the stamps (td_frame = 0); with the true td the residual vanishes to first
// order, with td = 0 or the opposite sign it does not.
TEST(ReprojectionTimeOffset, TrueDelayExplainsTheObservations) {
  const test::AnalyticTrajectory traj;
  std::mt19937 rng(11);
  const Eigen::Isometry3d T_b_c = downLookingCamera(rng);
  const double td_true = 0.01, t_i = 0.5, t_k = 0.8;
  auto camera = [&](double t) { return traj.pose(t) * T_b_c; };
  // A point 3 m in front of the camera at the anchor state time.
  const Eigen::Vector3d X = camera(t_i) * Eigen::Vector3d(0.3, -0.2, 3.0);
  auto project = [&](double t) { return Eigen::Vector2d((camera(t).inverse() * X).hnormalized()); };
  auto observe = [&](double t_stamp) {
    FeatureObservation o;
    const double t_exposure = t_stamp - td_true;
    o.uv = project(t_exposure);
    const double h = 1e-5;
    o.velocity = (project(t_exposure + h) - project(t_exposure - h)) / (2 * h);
    o.td_frame = 0.0;
    return o;
  };
  const FeatureObservation anchor = observe(t_i), target = observe(t_k);
  const double lambda = (X - camera(t_i).translation()).norm();
  auto residual = [&](double td) {
    return reprojectionResidual(anchor, target, traj.pose(t_i), traj.pose(t_k), T_b_c, lambda, td).norm();
  };
  EXPECT_GT(residual(0.0), 1e-3);  // the delay matters at this motion
  EXPECT_LT(residual(td_true), 0.05 * residual(0.0));
  EXPECT_GT(residual(-td_true), residual(0.0));
}

TEST(FactorJacobians, ReprojectionFactorRejectsPointsBehindTheCamera) {
  FeatureObservation anchor, target;
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_l_bk = I;
  T_l_bk.translation() = Eigen::Vector3d(0, 0, 5.0);  // camera = body, feature at z = 2 lies behind it
  const ReprojectionFactor factor(anchor, target, Eigen::Matrix2d::Identity());
  std::vector<std::vector<double>> params = {poseBlock(I), poseBlock(T_l_bk), poseBlock(I), {2.0}, {0.0}};
  std::vector<const double*> ptrs;
  for (auto& p : params) ptrs.push_back(p.data());
  double r[2];
  EXPECT_FALSE(factor.Evaluate(ptrs.data(), r, nullptr));
}

TEST(FactorJacobians, SonarDepthFactor) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(200 + seed);
    const Eigen::Isometry3d T_b_c = downLookingCamera(rng);
    Eigen::Isometry3d T_b_s = randomDownLookingPose(rng, 0.1, 0.3);
    const Eigen::Isometry3d T_l_bk = randomPose(rng, 0.4, 3.0);  // roll/pitch matter

    const FeatureObservation anchor = randomObservation(rng);
    const double range = 3.0 + randomVector(rng, 1.0).x();
    const double lambda = 3.0 + randomVector(rng, 1.0).x();
    const double td = randomVector(rng, 0.02).x();
    const SonarDepthFactor factor(anchor, range, T_b_s, 0.07);
    std::vector<std::vector<double>> params = {poseBlock(T_l_bk), poseBlock(T_b_c), {lambda}, {td}};
    worst = std::max(worst, test::checkJacobians(factor, params, {kPose, kPose, kEuclid, kEuclid}, kStep, kTol,
                                                 "sonar seed " + std::to_string(seed)));

    // The residual does not depend on the keyframe's position (it cancels).
    std::vector<std::vector<double>> moved = params;
    moved[0][0] += 1.3;
    moved[0][2] -= 0.7;
    EXPECT_NEAR(test::evaluateResidual(factor, moved)(0), test::evaluateResidual(factor, params)(0), 1e-12);
  }
  RecordProperty("worst_relative_error", test::sci(worst));
}

TEST(FactorJacobians, SeabedHeightFactor) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(300 + seed);
    const Eigen::Isometry3d T_b_c = downLookingCamera(rng);
    Eigen::Isometry3d T_l_bk = randomPose(rng, 0.4, 3.0);
    const FeatureObservation anchor = randomObservation(rng);
    const double lambda = 3.0 + randomVector(rng, 1.0).x();
    const double td = randomVector(rng, 0.02).x();
    const SeabedHeightFactor factor(anchor, SeabedPlane{-2.5 + randomVector(rng, 0.5).x()}, 0.3);
    std::vector<std::vector<double>> params = {poseBlock(T_l_bk), poseBlock(T_b_c), {lambda}, {td}};
    worst = std::max(worst, test::checkJacobians(factor, params, {kPose, kPose, kEuclid, kEuclid}, kStep, kTol,
                                                 "seabed seed " + std::to_string(seed)));
    // Unlike the sonar factor it pins the absolute height: raising the keyframe by 0.6 m
    // lowers the residual by 0.6 m / sigma; a horizontal move changes nothing.
    std::vector<std::vector<double>> raised = params, moved = params;
    raised[0][2] += 0.6;
    moved[0][0] += 1.3;
    EXPECT_NEAR(test::evaluateResidual(factor, raised)(0), test::evaluateResidual(factor, params)(0) - 0.6 / 0.3, 1e-9);
    EXPECT_NEAR(test::evaluateResidual(factor, moved)(0), test::evaluateResidual(factor, params)(0), 1e-12);
  }
  RecordProperty("worst_relative_error", test::sci(worst));
}

TEST(FactorJacobians, SlopedSonarDepthFactor) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(400 + seed);
    const Eigen::Isometry3d T_b_c = downLookingCamera(rng);
    Eigen::Isometry3d T_b_s = randomDownLookingPose(rng, 0.1, 0.3);
    Eigen::Isometry3d T_l_bk = randomPose(rng, 0.4, 3.0);
    const FeatureObservation anchor = randomObservation(rng);
    const double range = 3.0 + randomVector(rng, 1.0).x();
    const double lambda = 3.0 + randomVector(rng, 1.0).x();
    const double td = randomVector(rng, 0.02).x();
    const Eigen::Vector2d slope = randomVector(rng, 0.15).head<2>();  // up to ~8.5 deg
    const SlopedSonarDepthFactor factor(anchor, range, T_b_s, 0.07);
    std::vector<std::vector<double>> params = {
        poseBlock(T_l_bk), poseBlock(T_b_c), {lambda}, {td}, {slope.x(), slope.y()}};
    worst = std::max(worst, test::checkJacobians(factor, params, {kPose, kPose, kEuclid, kEuclid, kEuclid}, kStep, kTol,
                                                 "sloped sonar seed " + std::to_string(seed)));
    std::vector<std::vector<double>> moved = params;  // the keyframe's position still cancels
    moved[0][0] += 1.3;
    moved[0][2] -= 0.7;
    EXPECT_NEAR(test::evaluateResidual(factor, moved)(0), test::evaluateResidual(factor, params)(0), 1e-12);
    // With a zero gradient it is the horizontal-plane factor to the last bit.
    std::vector<std::vector<double>> level = params;
    level[4] = {0.0, 0.0};
    const SonarDepthFactor horizontal(anchor, range, T_b_s, 0.07);
    std::vector<std::vector<double>> four(params.begin(), params.begin() + 4);
    EXPECT_EQ(test::evaluateResidual(factor, level)(0), test::evaluateResidual(horizontal, four)(0));
  }
  RecordProperty("worst_relative_error", test::sci(worst));
}

TEST(FactorJacobians, SeabedHeightFactorOnASlopedPlane) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(500 + seed);
    const Eigen::Isometry3d T_b_c = downLookingCamera(rng);
    Eigen::Isometry3d T_l_bk = randomPose(rng, 0.4, 3.0);
    const FeatureObservation anchor = randomObservation(rng);
    const SeabedPlane plane{-2.5 + randomVector(rng, 0.5).x(), randomVector(rng, 4.0).head<2>(),
                            randomVector(rng, 0.15).head<2>()};
    const SeabedHeightFactor factor(anchor, plane, 0.3);
    std::vector<std::vector<double>> params = {
        poseBlock(T_l_bk), poseBlock(T_b_c), {3.0 + randomVector(rng, 1.0).x()}, {randomVector(rng, 0.02).x()}};
    worst = std::max(worst, test::checkJacobians(factor, params, {kPose, kPose, kEuclid, kEuclid}, kStep, kTol,
                                                 "sloped seabed seed " + std::to_string(seed)));
    // A horizontal move along the gradient by d changes the residual by |g| d (the seabed rises).
    std::vector<std::vector<double>> moved = params;
    const Eigen::Vector2d step = 0.8 * plane.slope.normalized();
    moved[0][0] += step.x();
    moved[0][1] += step.y();
    EXPECT_NEAR(test::evaluateResidual(factor, moved)(0) - test::evaluateResidual(factor, params)(0),
                plane.slope.dot(step) / 0.3, 1e-9);
  }
  RecordProperty("worst_relative_error", test::sci(worst));
}

TEST(FactorJacobians, WindowHitFactor) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(600 + seed);
    const Eigen::Isometry3d T_b_c = downLookingCamera(rng);
    Eigen::Isometry3d T_b_s = randomDownLookingPose(rng, 0.1, 0.3);
    Eigen::Isometry3d T_l_ba = randomPose(rng, 0.4, 3.0);
    Eigen::Isometry3d T_l_bj = randomPose(rng, 0.4, 1.5);  // within 1.5 m of the anchor keyframe
    T_l_bj.translation() += T_l_ba.translation();
    const FeatureObservation anchor = randomObservation(rng);
    const double range = 3.0 + randomVector(rng, 1.0).x();
    const Eigen::Vector2d slope = randomVector(rng, 0.15).head<2>();
    const SlopedWindowHitFactor sloped(anchor, range, T_b_s, 0.07);
    std::vector<std::vector<double>> params = {poseBlock(T_l_ba),
                                               poseBlock(T_l_bj),
                                               poseBlock(T_b_c),
                                               {3.0 + randomVector(rng, 1.0).x()},
                                               {randomVector(rng, 0.02).x()},
                                               {slope.x(), slope.y()}};
    worst = std::max(worst, test::checkJacobians(sloped, params, {kPose, kPose, kPose, kEuclid, kEuclid, kEuclid},
                                                 kStep, kTol, "sloped window hit seed " + std::to_string(seed)));
    const WindowHitFactor level(anchor, range, T_b_s, 0.07);
    std::vector<std::vector<double>> five(params.begin(), params.begin() + 5);
    worst = std::max(worst, test::checkJacobians(level, five, {kPose, kPose, kPose, kEuclid, kEuclid}, kStep, kTol,
                                                 "window hit seed " + std::to_string(seed)));
    // The anchor's own hit (j = a) is the sloped sonar depth factor.
    std::vector<std::vector<double>> own = params;
    own[1] = own[0];
    const SlopedSonarDepthFactor sonar(anchor, range, T_b_s, 0.07);
    const std::vector<std::vector<double>> sonar_params = {own[0], own[2], own[3], own[4], own[5]};
    EXPECT_NEAR(test::evaluateResidual(sloped, own)(0), test::evaluateResidual(sonar, sonar_params)(0), 1e-9);
    // Raising keyframe j by 0.2 m raises its hit, and the residual, by 0.2 m.
    std::vector<std::vector<double>> raised = params;
    raised[1][2] += 0.2;
    EXPECT_NEAR(test::evaluateResidual(sloped, raised)(0) - test::evaluateResidual(sloped, params)(0), 0.2 / 0.07,
                1e-9);
  }
  RecordProperty("worst_relative_error", test::sci(worst));
  FeatureObservation anchor;
  EXPECT_THROW(WindowHitFactor(anchor, 0.0, Eigen::Isometry3d::Identity(), 0.1), std::invalid_argument);
  EXPECT_THROW(SlopedWindowHitFactor(anchor, 2.0, Eigen::Isometry3d::Identity(), 0.0), std::invalid_argument);
}

TEST(SonarDepth, SlopedPlaneExplainsASlopingSeabedThatTheHorizontalOneCannot) {
  // Level body 3 m above a seabed sloping 4 deg up towards +x; the sonar hits it right below.
  Eigen::Isometry3d T_down = Eigen::Isometry3d::Identity();
  T_down.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Isometry3d T_l_b = Eigen::Isometry3d::Identity();
  const double g = std::tan(4.0 * M_PI / 180.0);
  const Eigen::Vector2d slope(g, 0.0);
  // Camera looking straight down from the body origin: the ray of uv hits z = -3 + g x.
  FeatureObservation anchor;
  anchor.uv = Eigen::Vector2d(0.5, 0.0);     // camera x = body x (rotation about x keeps it)
  const double z_c = 3.0 / (1.0 + g * 0.5);  // depth where -z_c = -3 + g (0.5 z_c)
  const double lambda = z_c * std::sqrt(1.0 + 0.25);
  EXPECT_NEAR(sonarDepthResidual(anchor, 3.0, T_down, T_l_b, T_down, lambda, 0.0, nullptr, slope), 0.0, 1e-12);
  // The horizontal plane sees the feature 1.4 m from the beam 0.1 m too high.
  EXPECT_NEAR(sonarDepthResidual(anchor, 3.0, T_down, T_l_b, T_down, lambda, 0.0), -g * 0.5 * z_c, 1e-12);
  EXPECT_GT(std::abs(sonarDepthResidual(anchor, 3.0, T_down, T_l_b, T_down, lambda, 0.0)), 0.09);
  EXPECT_NEAR(SeabedPlane({-3.0, Eigen::Vector2d::Zero(), slope}).heightAt(Eigen::Vector2d(0.5 * z_c, 0.0)), -z_c,
              1e-12);
}

TEST(SonarDepth, SeabedHeightEqualsSonarDepthAtTheMeasuredHeight) {
  // With h = the height the sonar measured at this keyframe, both residuals agree; the carried
  // sigma grows with the distance from the fix and the gate uses it.
  std::mt19937 rng(11);
  Eigen::Isometry3d T_b_s = randomDownLookingPose(rng, 0.1, 0.3);
  const Eigen::Isometry3d T_b_c = downLookingCamera(rng);
  Eigen::Isometry3d T_l_bk = Eigen::Isometry3d::Identity();
  T_l_bk.linear() = randomRotation(rng, 0.2).toRotationMatrix();
  T_l_bk.translation() = Eigen::Vector3d(1.0, -2.0, 3.5);
  const FeatureObservation anchor = randomObservation(rng);
  const double range = 3.2;
  const double h = (T_l_bk * (T_b_s * Eigen::Vector3d(0.0, 0.0, range))).z();
  for (double lambda : {2.5, 3.5, 4.5})
    EXPECT_NEAR(seabedHeightResidual(anchor, SeabedPlane{h}, T_l_bk, T_b_c, lambda, 0.01),
                sonarDepthResidual(anchor, range, T_b_s, T_l_bk, T_b_c, lambda, 0.01), 1e-12);
  SonarDepthOptions options;
  EXPECT_NEAR(options.carriedSigma(0.06, 0.0), 0.06, 1e-15);
  EXPECT_NEAR(options.carriedSigma(0.06, 8.0), std::hypot(0.06, 0.05 * 8.0), 1e-15);
  // 0.3 m off: inconsistent next to the fix, consistent 10 m away (sigma 0.5 m).
  const double lambda_on = 3.5;
  const double r_on = seabedHeightResidual(anchor, SeabedPlane{h}, T_l_bk, T_b_c, lambda_on, 0.0);
  options.gate_max_height_difference = 1.0;
  EXPECT_FALSE(seabedHeightGate(anchor, SeabedPlane{h + 0.3 - r_on}, T_l_bk, T_b_c, lambda_on, 0.0,
                                options.carriedSigma(0.06, 0.0), options)
                   .consistent);
  EXPECT_TRUE(seabedHeightGate(anchor, SeabedPlane{h + 0.3 - r_on}, T_l_bk, T_b_c, lambda_on, 0.0,
                               options.carriedSigma(0.06, 10.0), options)
                  .consistent);
  EXPECT_THROW(SeabedHeightFactor(anchor, SeabedPlane{std::nan("")}, 0.1), std::invalid_argument);
  EXPECT_THROW(SeabedHeightFactor(anchor, SeabedPlane{0.0}, 0.0), std::invalid_argument);
}

TEST(SonarDepth, ResidualIsHeightDifferenceAndGateFlagsOffPlaneFeatures) {
  // Level body 3 m above a flat seabed at z = 0, sonar and camera looking straight down.
  std::mt19937 rng(7);
  Eigen::Isometry3d T_down = Eigen::Isometry3d::Identity();
  T_down.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  Eigen::Isometry3d T_l_b = Eigen::Isometry3d::Identity();
  T_l_b.translation() = Eigen::Vector3d(1.0, 2.0, 3.0);
  FeatureObservation anchor;
  anchor.uv = Eigen::Vector2d(0.2, -0.1);
  const double lambda_true = 3.0 * std::sqrt(1.0 + 0.2 * 0.2 + 0.1 * 0.1);  // ray length to z = 0
  EXPECT_NEAR(sonarDepthResidual(anchor, 3.0, T_down, T_l_b, T_down, lambda_true, 0.0), 0.0, 1e-12);
  // Feature 0.2 m higher than the seabed (shorter ray): residual = seabed - feature height = -0.2.
  const double lambda_high = 2.8 * std::sqrt(1.0 + 0.2 * 0.2 + 0.1 * 0.1);
  EXPECT_NEAR(sonarDepthResidual(anchor, 3.0, T_down, T_l_b, T_down, lambda_high, 0.0), -0.2, 1e-12);

  const SonarDepthOptions options;
  const double sigma = options.sigma(0.02);
  EXPECT_TRUE(sonarDepthGate(anchor, 3.0, T_down, T_l_b, T_down, lambda_true, 0.0, sigma, options).consistent);
  const SonarGateResult off = sonarDepthGate(anchor, 3.0, T_down, T_l_b, T_down, lambda_high, 0.0, sigma, options);
  EXPECT_FALSE(off.consistent);  // 0.2 m at sigma ~5.4 cm: chi2 ~ 14 > 6.6
  EXPECT_NEAR(off.chi2, 0.04 / (sigma * sigma), 1e-9);
  SonarDepthOptions loose = options;
  loose.gate_chi2 = 100.0;
  EXPECT_TRUE(sonarDepthGate(anchor, 3.0, T_down, T_l_b, T_down, lambda_high, 0.0, sigma, loose).consistent);
  loose.gate_max_height_difference = 0.1;  // absolute gate alone rejects it
  EXPECT_FALSE(sonarDepthGate(anchor, 3.0, T_down, T_l_b, T_down, lambda_high, 0.0, sigma, loose).consistent);
  // The feature is (0.6, 0.3) m from the beam's hit; sigma grows by misfit_per_m (0.3) per metre
  // of that, so 0.2 m off at 0.67 m from the spot is relief, not a rock.
  const double distance = sonarHitDistance(anchor, 3.0, T_down, T_l_b, T_down, lambda_true, 0.0);
  EXPECT_NEAR(distance, 3.0 * std::sqrt(0.05), 1e-12);
  const double misfit = options.misfitPerM(std::nullopt, 40);  // nothing learnt yet: misfit_per_m
  EXPECT_DOUBLE_EQ(misfit, 0.3);
  EXPECT_NEAR(SonarDepthOptions::sigmaAt(sigma, 0.0, misfit), sigma, 1e-15);
  EXPECT_NEAR(SonarDepthOptions::sigmaAt(sigma, distance, misfit), std::hypot(sigma, 0.3 * distance), 1e-15);
  EXPECT_TRUE(sonarDepthGate(anchor, 3.0, T_down, T_l_b, T_down, lambda_high, 0.0,
                             SonarDepthOptions::sigmaAt(sigma, distance, misfit), options)
                  .consistent);
  (void)rng;
}

TEST(FactorJacobians, PressureDepthFactor) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(600 + seed);
    Eigen::Isometry3d T_l_bk = randomPose(rng, 0.4, 3.0);
    const Eigen::Vector3d p_bp = randomVector(rng, 0.5);
    const PressureDepthFactor factor(8.0 + randomVector(rng, 2.0).x(), p_bp, 0.01);
    std::vector<std::vector<double>> params = {poseBlock(T_l_bk), {12.0 + randomVector(rng, 1.0).x()}};
    worst = std::max(worst, test::checkJacobians(factor, params, {kPose, kEuclid}, kStep, kTol,
                                                 "pressure seed " + std::to_string(seed)));
    // It pins the port's absolute height: raising the body by 0.2 m or the surface by 0.2 m
    // moves the residual by +-0.2 m / sigma; a horizontal move changes nothing.
    std::vector<std::vector<double>> raised = params, surface = params, moved = params;
    raised[0][2] += 0.2;
    surface[1][0] += 0.2;
    moved[0][0] += 1.0;
    const double r0 = test::evaluateResidual(factor, params)(0);
    EXPECT_NEAR(test::evaluateResidual(factor, raised)(0), r0 + 20.0, 1e-9);
    EXPECT_NEAR(test::evaluateResidual(factor, surface)(0), r0 - 20.0, 1e-9);
    EXPECT_NEAR(test::evaluateResidual(factor, moved)(0), r0, 1e-12);
  }
  RecordProperty("worst_relative_error", test::sci(worst));
  // At the truth (port 10 m below a surface at z = 4) the residual vanishes.
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(1.0, 2.0, -6.2);
  EXPECT_NEAR(pressureDepthResidual(10.0, Eigen::Vector3d(0.0, 0.0, 0.2), T, 4.0), 0.0, 1e-12);
  EXPECT_THROW(PressureDepthFactor(std::nan(""), Eigen::Vector3d::Zero(), 0.01), std::invalid_argument);
  EXPECT_THROW(PressureDepthFactor(1.0, Eigen::Vector3d::Zero(), 0.0), std::invalid_argument);
}

TEST(FactorJacobians, SeabedSlopeRandomWalkAndPrior) {
  const SlopeRandomWalkFactor walk(0.05);
  std::vector<std::vector<double>> params = {{0.03, -0.02}, {0.05, 0.01}};
  test::checkJacobians(walk, params, {kEuclid, kEuclid}, kStep, kTol, "slope walk");
  const Eigen::Vector2d r = test::evaluateResidual(walk, params);
  EXPECT_NEAR(r(0), 0.02 / 0.05, 1e-12);
  EXPECT_NEAR(r(1), 0.03 / 0.05, 1e-12);
  const SlopePriorFactor prior(Eigen::Vector2d(0.01, 0.0), 0.1);
  std::vector<std::vector<double>> one = {{0.03, -0.02}};
  test::checkJacobians(prior, one, {kEuclid}, kStep, kTol, "slope prior");
  EXPECT_NEAR(test::evaluateResidual(prior, one)(0), 0.2, 1e-12);
  EXPECT_THROW(SlopeRandomWalkFactor(0.0), std::invalid_argument);
  EXPECT_THROW(SlopePriorFactor(Eigen::Vector2d::Zero(), -1.0), std::invalid_argument);
}

TEST(FactorJacobians, PosePriorFactor) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(300 + seed);
    const Eigen::Vector3d p0 = randomVector(rng, 3.0);
    const Eigen::Quaterniond q0 = randomRotation(rng, 3.0);
    Matrix6d S = Matrix6d::Random() * 0.3;
    S.diagonal() += Vector6d::Constant(2.0);
    S = S.triangularView<Eigen::Upper>();
    const PosePriorFactor factor(p0, q0, S);
    std::vector<std::vector<double>> params = {poseBlock(p0 + randomVector(rng, 1.0), q0 * randomRotation(rng, 0.8))};
    worst = std::max(worst,
                     test::checkJacobians(factor, params, {kPose}, kStep, kTol, "prior seed " + std::to_string(seed)));
  }
  RecordProperty("worst_relative_error", test::sci(worst));
}

TEST(PosePrior, PositionYawGaugeLeavesRollPitchFree) {
  const PosePriorFactor factor(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(),
                               PosePriorFactor::positionYawSqrtInformation(0.01, 0.01));
  auto cost = [&](const Eigen::Quaterniond& q) {
    return test::evaluateResidual(factor, {poseBlock(Eigen::Vector3d::Zero(), q)}).norm();
  };
  EXPECT_LT(cost(so3::exp(Eigen::Vector3d(0.2, -0.1, 0.0))), 0.03);         // roll/pitch: second order only
  EXPECT_NEAR(cost(so3::exp(Eigen::Vector3d(0.0, 0.0, 0.1))), 10.0, 1e-9);  // yaw: 0.1 rad / 0.01
}

TEST(FactorJacobians, RelativePoseFactor) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(400 + seed);
    const Eigen::Vector3d p_ij = randomVector(rng, 2.0);
    const Eigen::Quaterniond q_ij = randomRotation(rng, 1.0);
    Matrix6d S = Matrix6d::Identity() * 3.0;
    S(0, 4) = 0.5;
    S(2, 3) = -0.4;
    const RelativePoseFactor factor(p_ij, q_ij, S);
    const Eigen::Vector3d p_i = randomVector(rng, 3.0);
    const Eigen::Quaterniond q_i = randomRotation(rng, 3.0);
    std::vector<std::vector<double>> params = {poseBlock(p_i, q_i), poseBlock(p_i + q_i * p_ij + randomVector(rng, 0.5),
                                                                              q_i * q_ij * randomRotation(rng, 0.7))};
    worst = std::max(worst, test::checkJacobians(factor, params, {kPose, kPose}, kStep, kTol,
                                                 "relative seed " + std::to_string(seed)));
  }
  RecordProperty("worst_relative_error", test::sci(worst));
}

TEST(FactorJacobians, MarginalizationFactorAwayFromTheLinearisationPoint) {
  double worst = 0.0;
  for (unsigned seed : kSeeds) {
    std::mt19937 rng(500 + seed);
    auto prior = std::make_shared<MarginalizationPrior>();
    const std::vector<int> sizes = {7, 9, 7, 1};
    const std::vector<BlockManifold> manifolds = {kPose, kEuclid, kPose, kEuclid};
    std::vector<std::vector<double>> x0_blocks = {poseBlock(randomVector(rng, 2.0), randomRotation(rng, 3.0)),
                                                  std::vector<double>(9),
                                                  poseBlock(randomVector(rng, 2.0), randomRotation(rng, 3.0)),
                                                  {1.7}};
    for (double& v : x0_blocks[1]) v = randomVector(rng, 1.0).x();
    for (size_t b = 0; b < sizes.size(); ++b) {
      prior->blocks.push_back(x0_blocks[b].data());
      prior->ambient_sizes.push_back(sizes[b]);
      prior->manifolds.push_back(manifolds[b]);
      prior->x0.push_back(Eigen::Map<const Eigen::VectorXd>(x0_blocks[b].data(), sizes[b]));
    }
    prior->J = Eigen::MatrixXd::Random(18, 22);
    prior->r0 = Eigen::VectorXd::Random(18);
    const MarginalizationFactor factor(prior);

    // Evaluate away from x0 (rotations 0.6 rad off) so Jr^{-1} in the pose difference matters.
    std::vector<std::vector<double>> params = x0_blocks;
    Eigen::Matrix<double, 6, 1> d;
    for (int b : {0, 2}) {
      d << randomVector(rng, 0.5), randomVector(rng, 0.6);
      PoseManifold().Plus(x0_blocks[b].data(), d.data(), params[b].data());
    }
    for (double& v : params[1]) v += randomVector(rng, 0.3).x();
    params[3][0] += 0.4;
    worst = std::max(worst, test::checkJacobians(factor, params, manifolds, kStep, kTol,
                                                 "marginalization seed " + std::to_string(seed)));

    // At x0 the residual is r0.
    EXPECT_LT((test::evaluateResidual(factor, x0_blocks) - prior->r0).norm(), 1e-12);
  }
  RecordProperty("worst_relative_error", test::sci(worst));
}

}  // namespace
}  // namespace vims
