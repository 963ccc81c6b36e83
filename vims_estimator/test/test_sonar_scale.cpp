// End to end: a tiny sliding-window problem (three keyframes, IMU factors, reprojection factors
// with direct depth, sonar depth factors) on a constant-velocity trajectory. Without acceleration
// the IMU cannot tell the speed, so the visual-inertial problem has a scale null direction; the
// sonar depth factors remove it and the solver recovers the true scale from a wrong start.
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "analytic_trajectory.h"
#include "test_utils.h"
#include "vims_estimator/factors/imu_factor.h"
#include "vims_estimator/factors/reprojection_factor.h"
#include "vims_estimator/factors/sonar_depth_factor.h"

namespace vims {
namespace {

struct Scene {
  test::AnalyticTrajectory traj = test::AnalyticTrajectory::constantVelocity(Eigen::Vector3d(0.0, 0.0, 3.0),
                                                                             Eigen::Vector3d(0.4, 0.15, 0.0), 0.3, 0.1);
  std::vector<double> times = {0.0, 0.5, 1.0};
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_b_s = Eigen::Isometry3d::Identity();
  std::vector<FeatureObservation> anchors;               // in keyframe 0
  std::vector<std::vector<FeatureObservation>> targets;  // [feature][keyframe 1, 2]
  std::vector<double> lambda_true;
  double range0 = 0.0;  // sonar range at keyframe 0
  std::vector<std::shared_ptr<ImuPreintegration>> preintegrations;
  ImuNoiseParams noise;

  Scene() {
    // Down-looking camera at the IMU origin (no lever arm, so VIO has an exact scale null
    // direction); the sonar is offset and slightly tilted.
    T_b_c.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
    T_b_s.linear() =
        (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()))
            .toRotationMatrix();
    T_b_s.translation() = Eigen::Vector3d(-0.15, 0.05, -0.1);

    // Sonar: intersection of the beam with the seabed plane z = 0.
    const Eigen::Isometry3d T_l_b0 = traj.pose(times[0]);
    const Eigen::Vector3d origin = T_l_b0 * T_b_s.translation();
    const Eigen::Vector3d beam = T_l_b0.linear() * T_b_s.linear().col(2);
    range0 = -origin.z() / beam.z();

    std::mt19937 rng(42);
    std::uniform_real_distribution<double> u(-0.35, 0.35);
    for (int j = 0; j < 25; ++j) {
      FeatureObservation a;
      a.uv = Eigen::Vector2d(u(rng), u(rng));
      // Ray from the anchor camera to the seabed z = 0.
      const Eigen::Isometry3d T_l_c0 = T_l_b0 * T_b_c;
      const Eigen::Vector3d ray_l = T_l_c0.linear() * a.uv.homogeneous().normalized();
      const double lambda = -T_l_c0.translation().z() / ray_l.z();
      anchors.push_back(a);
      lambda_true.push_back(lambda);
      std::vector<FeatureObservation> obs;
      for (int k = 1; k < 3; ++k) {
        FeatureObservation t;  // uv = 0: the residual is then the projection itself
        const Eigen::Vector2d proj = reprojectionResidual(a, t, T_l_b0, traj.pose(times[k]), T_b_c, lambda, 0.0);
        t.uv = proj;
        obs.push_back(t);
      }
      targets.push_back(obs);
    }

    noise.gyro_noise_density = 1.7e-4;
    noise.accel_noise_density = 2e-3;
    noise.gyro_random_walk = 2e-5;
    noise.accel_random_walk = 3e-3;
    for (int k = 0; k + 1 < 3; ++k) {
      std::vector<ImuSample> samples;
      for (int i = 0; i <= 100; ++i) samples.push_back(traj.imu(times[k] + i / 200.0));
      preintegrations.push_back(std::make_shared<ImuPreintegration>(
          ImuPreintegration::fromSamples(samples, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), noise)));
    }
  }
};

struct Result {
  double scale = 0.0;             // estimated / true distance travelled
  double lambda_rel_error = 0.0;  // max |lambda / lambda_true - 1|
  double min_eigen_ratio = 0.0;   // smallest / largest eigenvalue of J^T J at the solution
};

/// Builds and solves the window starting from the truth scaled by `initial_scale` (positions
/// about keyframe 0, velocities and depths), with or without the sonar depth factors.
Result solve(const Scene& s, double initial_scale, bool use_sonar) {
  std::vector<std::vector<double>> poses, speed_bias;
  const Eigen::Vector3d p0 = s.traj.position(s.times[0]);
  std::mt19937 rng(9);
  for (int k = 0; k < 3; ++k) {
    const double t = s.times[k];
    // Scaled start plus a little noise so the solver has to move.
    const Eigen::Vector3d noise = k == 0 ? Eigen::Vector3d::Zero() : test::randomVector(rng, 0.02);
    poses.push_back(test::poseBlock(p0 + initial_scale * (s.traj.position(t) - p0) + noise, s.traj.rotation(t)));
    std::vector<double> sb(9, 0.0);
    Eigen::Map<Eigen::Vector3d>(sb.data()) = initial_scale * s.traj.velocity(t);
    speed_bias.push_back(sb);
  }
  std::vector<double> lambdas;
  for (double l : s.lambda_true) lambdas.push_back(initial_scale * l);
  std::vector<double> T_b_c = test::poseBlock(s.T_b_c);
  double td = 0.0;

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold pose_manifold;
  ceres::SubsetManifold biases_fixed(9, {3, 4, 5, 6, 7, 8});  // the biases are not the point here
  for (int k = 0; k < 3; ++k) {
    problem.AddParameterBlock(poses[k].data(), 7, &pose_manifold);
    problem.AddParameterBlock(speed_bias[k].data(), 9, &biases_fixed);
  }
  problem.AddParameterBlock(T_b_c.data(), 7, &pose_manifold);
  problem.SetParameterBlockConstant(T_b_c.data());
  problem.AddParameterBlock(&td, 1);
  problem.SetParameterBlockConstant(&td);
  problem.SetParameterBlockConstant(poses[0].data());  // gauge: first pose fixed

  for (int k = 0; k + 1 < 3; ++k) {
    problem.AddResidualBlock(new ImuFactor(s.preintegrations[k], s.traj.gravityWorld()), nullptr, poses[k].data(),
                             speed_bias[k].data(), poses[k + 1].data(), speed_bias[k + 1].data());
  }
  const Eigen::Matrix2d sqrt_info = Eigen::Matrix2d::Identity() * (460.0 / 1.5);  // focal / pixel sigma
  for (size_t j = 0; j < s.anchors.size(); ++j) {
    for (int k = 1; k < 3; ++k) {
      problem.AddResidualBlock(new ReprojectionFactor(s.anchors[j], s.targets[j][k - 1], sqrt_info), nullptr,
                               poses[0].data(), poses[k].data(), T_b_c.data(), &lambdas[j], &td);
    }
    if (use_sonar) {
      const double sigma = SonarDepthOptions().sigma(0.02);
      problem.AddResidualBlock(new SonarDepthFactor(s.anchors[j], s.range0, s.T_b_s, sigma), new ceres::HuberLoss(1.0),
                               poses[0].data(), T_b_c.data(), &lambdas[j], &td);
    }
  }

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 100;
  options.function_tolerance = 1e-14;
  options.gradient_tolerance = 1e-14;
  options.parameter_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  EXPECT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();

  Result res;
  res.scale = (posePosition(poses[2].data()) - posePosition(poses[0].data())).norm() /
              (s.traj.position(s.times[2]) - p0).norm();
  for (size_t j = 0; j < lambdas.size(); ++j) {
    res.lambda_rel_error = std::max(res.lambda_rel_error, std::abs(lambdas[j] / s.lambda_true[j] - 1.0));
  }
  // Conditioning of the Gauss-Newton Hessian at the solution (free parameters, tangent space).
  ceres::CRSMatrix crs;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), nullptr, nullptr, nullptr, &crs);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r) {
    for (int i = crs.rows[r]; i < crs.rows[r + 1]; ++i) J(r, crs.cols[i]) = crs.values[i];
  }
  // Ceres reports constant blocks (pose 0, T_b_c, td) as zero columns: keep the free ones.
  std::vector<int> free_cols;
  for (int c = 0; c < J.cols(); ++c) {
    if (J.col(c).cwiseAbs().maxCoeff() > 0.0) free_cols.push_back(c);
  }
  EXPECT_EQ(free_cols.size(), 2 * 6 + 3 * 3 + s.anchors.size());  // poses 1-2, velocities, depths
  Eigen::MatrixXd J_free(J.rows(), free_cols.size());
  for (size_t i = 0; i < free_cols.size(); ++i) J_free.col(i) = J.col(free_cols[i]);
  const Eigen::VectorXd ev = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(J_free.transpose() * J_free).eigenvalues();
  res.min_eigen_ratio = ev.minCoeff() / ev.maxCoeff();
  return res;
}

TEST(SonarScale, SonarDepthFactorRecoversTheScaleThatImuCannot) {
  const Scene scene;
  ASSERT_GT(scene.range0, 2.5);

  const Result without = solve(scene, 0.6, false);
  const Result with = solve(scene, 0.6, true);

  RecordProperty("scale_without_sonar", test::sci(without.scale));
  RecordProperty("scale_with_sonar", test::sci(with.scale));
  RecordProperty("eigen_ratio_without_sonar", test::sci(without.min_eigen_ratio));
  RecordProperty("eigen_ratio_with_sonar", test::sci(with.min_eigen_ratio));
  RecordProperty("lambda_rel_error_with_sonar", test::sci(with.lambda_rel_error));

  // Without sonar: a null direction (scale) remains and the solver stays near the wrong start.
  EXPECT_LT(without.min_eigen_ratio, 1e-12) << "VIO at constant velocity must have a scale null direction";
  EXPECT_GT(std::abs(without.scale - 1.0), 0.3) << "scale " << without.scale;

  // With sonar: well conditioned and the true scale and depths are recovered.
  EXPECT_GT(with.min_eigen_ratio, 1e-10);
  EXPECT_NEAR(with.scale, 1.0, 1e-4);
  EXPECT_LT(with.lambda_rel_error, 1e-4);
}

}  // namespace
}  // namespace vims
