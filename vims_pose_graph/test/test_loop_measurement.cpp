// The known-vertical loop refinement (refineLoopMeasurement): it undoes a PnP tilt error, and its
// covariance matches the closed form of a nadir camera over a symmetric grid, where the four
// parameters decouple:
//   sigma_x = sigma_y = s h / sqrt(N),  sigma_z = s h / sqrt(sum |u_i|^2),  sigma_yaw = s / sqrt(sum |u_i|^2)
// (u_i the normalised image points, h the height, s the residual RMS with 4 dof taken out).
#include <gtest/gtest.h>

#include <cmath>

#include "vims_pose_graph/loop_measurement.h"

namespace vims {
namespace {

/// Camera looking straight down from the body (camera z = -body z).
Eigen::Isometry3d downwardCamera() {
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  T_b_c.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return T_b_c;
}

struct Scene {
  LoopInlierGeometry inliers;
  Eigen::Isometry3d T_odomq_bq = Eigen::Isometry3d::Identity();
  double sum_u2 = 0.0;
  double s = 0.0;
};

/// A (2k+1)^2 grid of seabed points at z = 0, spacing `spacing`, seen from height h by the match
/// camera at the query's pose; every observation off by +-eps in a pattern whose sums vanish.
Scene nadirScene(int k, double spacing, double h, double eps) {
  Scene sc;
  sc.T_odomq_bq.translation() = Eigen::Vector3d(0.0, 0.0, h);
  const Eigen::Isometry3d T_c_odom = (sc.T_odomq_bq * downwardCamera()).inverse();
  double sum_r2 = 0.0;
  for (int i = -k; i <= k; ++i) {
    for (int j = -k; j <= k; ++j) {
      const Eigen::Vector3d p(i * spacing, j * spacing, 0.0);
      const Eigen::Vector3d p_c = T_c_odom * p;
      const Eigen::Vector2d u = p_c.head<2>() / p_c.z();
      const double sign = ((i + j) % 2 == 0) ? 1.0 : -1.0;
      const Eigen::Vector2d offset(sign * eps, -sign * eps);
      sc.inliers.points_odom_query.push_back(p);
      sc.inliers.normalized_match.push_back(u + offset);
      sc.sum_u2 += u.squaredNorm();
      sum_r2 += offset.squaredNorm();
    }
  }
  const double n = static_cast<double>(sc.inliers.points_odom_query.size());
  sc.s = std::sqrt(sum_r2 / (2.0 * n - 4.0));
  return sc;
}

TEST(LoopMeasurement, NadirCameraMatchesClosedForm) {
  const double h = 3.0;
  const Scene sc = nadirScene(/*k=*/4, /*spacing=*/0.25, h, /*eps=*/1e-3);
  const auto c =
      refineLoopMeasurement(sc.inliers, Eigen::Isometry3d::Identity(), sc.T_odomq_bq, downwardCamera(), 0.0, 0.0);
  ASSERT_TRUE(c.has_value());
  const double n = static_cast<double>(sc.inliers.points_odom_query.size());
  // The offsets' sums nearly vanish, so the optimum and s barely move from the truth.
  EXPECT_NEAR(c->residual_rms, sc.s, 1e-3 * sc.s);
  EXPECT_LT(c->T_match_query.translation().norm(), 1e-4);
  const Eigen::Vector4d sigma = c->covariance.diagonal().cwiseSqrt();
  const double s = c->residual_rms;
  EXPECT_NEAR(sigma[0], s * h / std::sqrt(n), 1e-3 * sigma[0]);
  EXPECT_NEAR(sigma[1], s * h / std::sqrt(n), 1e-3 * sigma[1]);
  EXPECT_NEAR(sigma[2], s * h / std::sqrt(sc.sum_u2), 1e-3 * sigma[2]);
  EXPECT_NEAR(sigma[3], s / std::sqrt(sc.sum_u2), 1e-3 * sigma[3]);
  // Decoupled: the off-diagonal terms vanish on the symmetric grid.
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b)
      if (a != b) {
        EXPECT_NEAR(c->covariance(a, b), 0.0, 1e-3 * std::sqrt(c->covariance(a, a) * c->covariance(b, b)));
      }
}

TEST(LoopMeasurement, UndoesThePnpTiltAndItsLateralShift) {
  // Exact observations of a query 0.4 m ahead and 10 deg turned; the PnP pose is tilted by 1 deg
  // and shifted 5 cm sideways (what PnP trades over a flat seabed). Held at the VIO's level
  // attitude, the refinement returns the true pose.
  const double h = 3.0;
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  T_match_query.linear() = Eigen::AngleAxisd(10.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_match_query.translation() = Eigen::Vector3d(0.4, 0.0, 0.0);
  Eigen::Isometry3d T_odomq_bq = Eigen::Isometry3d::Identity();
  T_odomq_bq.translation() = Eigen::Vector3d(2.0, 1.0, h);
  // Match camera in the query odom frame: T_odomq_bm = T_odomq_bq T_match_query^-1.
  const Eigen::Isometry3d T_c_odom = (T_odomq_bq * T_match_query.inverse() * downwardCamera()).inverse();
  LoopInlierGeometry g;
  for (int i = -3; i <= 3; ++i)
    for (int j = -3; j <= 3; ++j) {
      const Eigen::Vector3d p(2.0 + 0.3 * i + 0.05 * j * j, 1.0 + 0.3 * j, 0.1 * std::sin(i + 2.0 * j));
      const Eigen::Vector3d p_c = T_c_odom * p;
      g.points_odom_query.push_back(p);
      g.normalized_match.push_back(p_c.head<2>() / p_c.z());
    }
  Eigen::Isometry3d pnp = T_match_query;
  pnp.linear() = Eigen::AngleAxisd(1.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix() * pnp.linear();
  pnp.translation() += Eigen::Vector3d(0.0, 0.05, 0.0);
  const auto m = refineLoopMeasurement(g, pnp, T_odomq_bq, downwardCamera(), 0.0, 0.0);
  ASSERT_TRUE(m.has_value());
  EXPECT_LT((m->T_match_query.translation() - T_match_query.translation()).norm(), 1e-6);
  EXPECT_TRUE(m->T_match_query.linear().isApprox(T_match_query.linear(), 1e-6));
  EXPECT_LT(m->residual_rms, 1e-6);
  EXPECT_GT(m->iterations, 0);
}

TEST(LoopMeasurement, MoreInliersAndSmallerResidualsTightenIt) {
  const Scene few = nadirScene(2, 0.5, 3.0, 1e-3);
  const Scene many = nadirScene(4, 0.25, 3.0, 1e-3);
  const Scene noisy = nadirScene(4, 0.25, 3.0, 3e-3);
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  const auto c_few = refineLoopMeasurement(few.inliers, I, few.T_odomq_bq, downwardCamera(), 0.0, 0.0);
  const auto c_many = refineLoopMeasurement(many.inliers, I, many.T_odomq_bq, downwardCamera(), 0.0, 0.0);
  const auto c_noisy = refineLoopMeasurement(noisy.inliers, I, noisy.T_odomq_bq, downwardCamera(), 0.0, 0.0);
  ASSERT_TRUE(c_few && c_many && c_noisy);
  EXPECT_LT(c_many->covariance(0, 0), c_few->covariance(0, 0));
  EXPECT_NEAR(c_noisy->covariance(0, 0), 9.0 * c_many->covariance(0, 0), 1e-2 * c_noisy->covariance(0, 0));
}

TEST(LoopMeasurement, TiltedMatchKeepsTheLevelledFrame) {
  // A match tilted by its VIO pitch/roll: the position sigmas are in its levelled frame, so a
  // nadir-symmetric scene seen by a camera whose body is levelled by (pitch, roll) gives the
  // same sigmas as the untilted case.
  const double h = 3.0;
  const Scene sc = nadirScene(3, 0.3, h, 1e-3);
  const auto level =
      refineLoopMeasurement(sc.inliers, Eigen::Isometry3d::Identity(), sc.T_odomq_bq, downwardCamera(), 0.0, 0.0);
  const double pitch = 0.1, roll = -0.05;
  // Match and query share the tilted attitude; the query sees the same image as before when its
  // camera is the same: tilt the body and counter-rotate the camera mounting.
  const Eigen::Matrix3d L =
      (Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  Eigen::Isometry3d T_odomq_bq = sc.T_odomq_bq;
  T_odomq_bq.linear() = L;
  Eigen::Isometry3d T_b_c = downwardCamera();
  T_b_c.linear() = L.transpose() * T_b_c.linear();
  const auto tilted = refineLoopMeasurement(sc.inliers, Eigen::Isometry3d::Identity(), T_odomq_bq, T_b_c, pitch, roll);
  ASSERT_TRUE(level && tilted);
  EXPECT_TRUE(tilted->covariance.isApprox(level->covariance, 1e-4));
}

TEST(LoopMeasurement, DegenerateInputsGiveNone) {
  const Scene sc = nadirScene(2, 0.5, 3.0, 1e-3);
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  LoopInlierGeometry three = sc.inliers;
  three.points_odom_query.resize(3);
  three.normalized_match.resize(3);
  EXPECT_FALSE(refineLoopMeasurement(three, I, sc.T_odomq_bq, downwardCamera(), 0.0, 0.0).has_value());
  LoopInlierGeometry mismatched = sc.inliers;
  mismatched.normalized_match.pop_back();
  EXPECT_FALSE(refineLoopMeasurement(mismatched, I, sc.T_odomq_bq, downwardCamera(), 0.0, 0.0).has_value());
  LoopInlierGeometry behind = sc.inliers;
  behind.points_odom_query[0].z() = 10.0;  // above the camera
  EXPECT_FALSE(refineLoopMeasurement(behind, I, sc.T_odomq_bq, downwardCamera(), 0.0, 0.0).has_value());
  // All points on one spot: position along the view and yaw are not constrained.
  LoopInlierGeometry one_spot = sc.inliers;
  for (auto& p : one_spot.points_odom_query) p = Eigen::Vector3d::Zero();
  for (auto& u : one_spot.normalized_match) u = Eigen::Vector2d(1e-3, 0.0);
  EXPECT_FALSE(refineLoopMeasurement(one_spot, I, sc.T_odomq_bq, downwardCamera(), 0.0, 0.0).has_value());
}

}  // namespace
}  // namespace vims
