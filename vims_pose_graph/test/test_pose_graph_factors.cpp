// Residual math of the 4-DoF pose graph: analytic Jacobians against central differences, the
// geomagnetic heading against a synthetic Earth field, and angle wrapping.

#include <gtest/gtest.h>

#include <random>

#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/pose_graph_factors.h"

namespace vims {
namespace {

constexpr double kDeg = M_PI / 180.0;

/// Earth's field in ENU for total intensity F, inclination I (down positive) and declination D.
Eigen::Vector3d earthFieldEnu(double F, double inclination, double declination) {
  return F * Eigen::Vector3d(std::cos(inclination) * std::sin(declination),
                             std::cos(inclination) * std::cos(declination), -std::sin(inclination));
}

/// Central difference of a vector function of one scalar.
template <typename F>
Eigen::VectorXd numericDerivative(F f, double x, double h = 1e-6) {
  return (f(x + h) - f(x - h)) / (2 * h);
}

TEST(Angles, WrapAndYawPitchRollRoundTrip) {
  EXPECT_NEAR(wrapAngle(3 * M_PI / 2), -M_PI / 2, 1e-12);
  EXPECT_NEAR(wrapAngle(-3 * M_PI / 2), M_PI / 2, 1e-12);
  EXPECT_NEAR(wrapAngle(0.3 + 8 * M_PI), 0.3, 1e-9);
  EXPECT_LE(std::abs(wrapAngle(M_PI)), M_PI);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> yaw(-M_PI, M_PI), tilt(-0.5, 0.5);
  for (int i = 0; i < 100; ++i) {
    const double y = yaw(rng), p = tilt(rng), r = tilt(rng);
    const YawPitchRoll ypr = yawPitchRollFromRotation(rotationFromYawPitchRoll(y, p, r));
    EXPECT_NEAR(wrapAngle(ypr.yaw - y), 0.0, 1e-12);
    EXPECT_NEAR(ypr.pitch, p, 1e-12);
    EXPECT_NEAR(ypr.roll, r, 1e-12);
  }
}

TEST(Angles, ManifoldWrapsAcrossPi) {
  AngleManifold m;
  const double x = 179 * kDeg, dx = 3 * kDeg;
  double y = 0.0;
  ASSERT_TRUE(m.Plus(&x, &dx, &y));
  EXPECT_NEAR(y, -178 * kDeg, 1e-12);
  double back = 0.0;
  ASSERT_TRUE(m.Minus(&y, &x, &back));
  EXPECT_NEAR(back, dx, 1e-12);
  double J = 0.0;
  ASSERT_TRUE(m.PlusJacobian(&x, &J));
  EXPECT_EQ(J, 1.0);
  ASSERT_TRUE(m.MinusJacobian(&x, &J));
  EXPECT_EQ(J, 1.0);
}

TEST(RelativePose4Dof, FromRelativeMatchesFromPoses) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> yaw(-M_PI, M_PI), tilt(-0.3, 0.3), pos(-5, 5);
  for (int i = 0; i < 50; ++i) {
    Eigen::Isometry3d T_a_i = Eigen::Isometry3d::Identity(), T_a_j = Eigen::Isometry3d::Identity();
    const double pitch_i = tilt(rng), roll_i = tilt(rng);
    T_a_i.linear() = rotationFromYawPitchRoll(yaw(rng), pitch_i, roll_i);
    T_a_i.translation() = Eigen::Vector3d(pos(rng), pos(rng), pos(rng));
    T_a_j.linear() = rotationFromYawPitchRoll(yaw(rng), tilt(rng), tilt(rng));
    T_a_j.translation() = Eigen::Vector3d(pos(rng), pos(rng), pos(rng));
    const RelativePose4Dof a = relativePose4DofFromPoses(T_a_i, T_a_j);
    const RelativePose4Dof b = relativePose4DofFromRelative(T_a_i.inverse() * T_a_j, pitch_i, roll_i);
    EXPECT_LT((a.p_li_j - b.p_li_j).norm(), 1e-9);
    EXPECT_NEAR(wrapAngle(a.yaw_i_j - b.yaw_i_j), 0.0, 1e-9);
    // Invariance to a 4-DoF change of frame (what lets VIO edges constrain world poses).
    Eigen::Isometry3d T_w_a = Eigen::Isometry3d::Identity();
    T_w_a.linear() = rotationZ(yaw(rng));
    T_w_a.translation() = Eigen::Vector3d(pos(rng), pos(rng), pos(rng));
    const RelativePose4Dof c = relativePose4DofFromPoses(T_w_a * T_a_i, T_w_a * T_a_j);
    EXPECT_LT((a.p_li_j - c.p_li_j).norm(), 1e-9);
    EXPECT_NEAR(wrapAngle(a.yaw_i_j - c.yaw_i_j), 0.0, 1e-9);
  }
}

TEST(RelativePose4Dof, AnalyticJacobiansMatchCentralDifferences) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> yaw(-M_PI, M_PI), pos(-10, 10), small(-0.5, 0.5);
  for (int trial = 0; trial < 30; ++trial) {
    const Eigen::Vector3d p_i(pos(rng), pos(rng), pos(rng)), p_j(pos(rng), pos(rng), pos(rng));
    const double yaw_i = yaw(rng), yaw_j = yaw(rng);
    RelativePose4Dof z;
    z.p_li_j = Eigen::Vector3d(pos(rng), pos(rng), pos(rng));
    // Keep the yaw error away from +-pi, where the wrapped residual jumps.
    z.yaw_i_j = wrapAngle(yaw_j - yaw_i + small(rng));
    Eigen::Matrix<double, 4, 3> J_p_i, J_p_j;
    Eigen::Vector4d J_y_i, J_y_j;
    relativePose4DofResidual(p_i, yaw_i, p_j, yaw_j, z, &J_p_i, &J_y_i, &J_p_j, &J_y_j);
    for (int k = 0; k < 3; ++k) {
      auto f_i = [&](double v) {
        Eigen::Vector3d p = p_i;
        p[k] = v;
        return Eigen::VectorXd(relativePose4DofResidual(p, yaw_i, p_j, yaw_j, z));
      };
      auto f_j = [&](double v) {
        Eigen::Vector3d p = p_j;
        p[k] = v;
        return Eigen::VectorXd(relativePose4DofResidual(p_i, yaw_i, p, yaw_j, z));
      };
      EXPECT_LT((numericDerivative(f_i, p_i[k]) - J_p_i.col(k)).norm(), 1e-6);
      EXPECT_LT((numericDerivative(f_j, p_j[k]) - J_p_j.col(k)).norm(), 1e-6);
    }
    auto g_i = [&](double v) { return Eigen::VectorXd(relativePose4DofResidual(p_i, v, p_j, yaw_j, z)); };
    auto g_j = [&](double v) { return Eigen::VectorXd(relativePose4DofResidual(p_i, yaw_i, p_j, v, z)); };
    EXPECT_LT((numericDerivative(g_i, yaw_i) - J_y_i).norm(), 1e-6);
    EXPECT_LT((numericDerivative(g_j, yaw_j) - J_y_j).norm(), 1e-6);
  }
}

TEST(RelativePose4Dof, CeresFactorWhitensResidualAndJacobians) {
  RelativePose4Dof z;
  z.p_li_j = Eigen::Vector3d(1, 2, 0.5);
  z.yaw_i_j = 0.3;
  const Eigen::Vector4d sqrt_info(10, 20, 30, 40);
  RelativePose4DofFactor factor(z, sqrt_info);
  Eigen::Vector3d p_i(0.1, -0.2, 0.3), p_j(1.5, 1.0, 0.2);
  double yaw_i = 0.7, yaw_j = 1.1;
  const double* params[] = {p_i.data(), &yaw_i, p_j.data(), &yaw_j};
  Eigen::Vector4d r;
  Eigen::Matrix<double, 4, 3, Eigen::RowMajor> J0, J2;
  Eigen::Vector4d J1, J3;
  double* jac[] = {J0.data(), J1.data(), J2.data(), J3.data()};
  ASSERT_TRUE(factor.Evaluate(params, r.data(), jac));
  Eigen::Matrix<double, 4, 3> A0, A2;
  Eigen::Vector4d A1, A3;
  const Eigen::Vector4d raw = relativePose4DofResidual(p_i, yaw_i, p_j, yaw_j, z, &A0, &A1, &A2, &A3);
  EXPECT_LT((r - sqrt_info.cwiseProduct(raw)).norm(), 1e-12);
  EXPECT_LT((Eigen::Matrix<double, 4, 3>(J0) - sqrt_info.asDiagonal() * A0).norm(), 1e-12);
  EXPECT_LT((J1 - sqrt_info.cwiseProduct(A1)).norm(), 1e-12);
  EXPECT_LT((Eigen::Matrix<double, 4, 3>(J2) - sqrt_info.asDiagonal() * A2).norm(), 1e-12);
  EXPECT_LT((J3 - sqrt_info.cwiseProduct(A3)).norm(), 1e-12);
  // Residual only (no Jacobians requested).
  Eigen::Vector4d r2;
  ASSERT_TRUE(factor.Evaluate(params, r2.data(), nullptr));
  EXPECT_EQ(r, r2);
}

TEST(RelativePose4Dof, YawResidualWrapsAroundPi) {
  RelativePose4Dof z;
  z.yaw_i_j = 4 * kDeg;
  // yaw_i = 178 deg, yaw_j = -178 deg: the true difference is +4 deg, not -356 deg.
  const Eigen::Vector4d r =
      relativePose4DofResidual(Eigen::Vector3d::Zero(), 178 * kDeg, Eigen::Vector3d::Zero(), -178 * kDeg, z);
  EXPECT_NEAR(r[3], 0.0, 1e-12);
  z.yaw_i_j = 0.0;
  EXPECT_NEAR(relativePose4DofResidual(Eigen::Vector3d::Zero(), -179 * kDeg, Eigen::Vector3d::Zero(), 179 * kDeg, z)[3],
              -2 * kDeg, 1e-12);
}

TEST(GeomagneticYaw, HeadingFromTiltedBodyField) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> yaw(-M_PI, M_PI), tilt(-0.4, 0.4);
  for (double declination : {0.0, 10 * kDeg, -25 * kDeg}) {
    const Eigen::Vector3d B_w = earthFieldEnu(50e-6, 60 * kDeg, declination);
    const Eigen::Vector2d north = magneticNorthEnu(declination);
    for (int i = 0; i < 50; ++i) {
      const double y = yaw(rng), p = tilt(rng), r = tilt(rng);
      const Eigen::Vector3d B_b = rotationFromYawPitchRoll(y, p, r).transpose() * B_w;
      Eigen::Vector2d u_l;
      double horizontal = 0.0;
      ASSERT_TRUE(levelledFieldDirection(B_b, p, r, 1e-6, &u_l, &horizontal));
      EXPECT_NEAR(horizontal, 50e-6 * std::cos(60 * kDeg), 1e-12);
      EXPECT_NEAR(wrapAngle(headingFromLevelledField(u_l, north) - y), 0.0, 1e-9);
      EXPECT_LT(geomagneticYawResidual(y, u_l, north).norm(), 1e-9);
      // |r| = 2 |sin(e / 2)| for a heading error e.
      const double e = 0.3;
      EXPECT_NEAR(geomagneticYawResidual(y + e, u_l, north).norm(), 2 * std::sin(e / 2), 1e-9);
    }
  }
  // ENU sanity: a level body facing east (yaw 0) with D = 0 sees the field along its +y (left).
  Eigen::Vector2d u_l;
  ASSERT_TRUE(levelledFieldDirection(earthFieldEnu(50e-6, 60 * kDeg, 0.0), 0, 0, 1e-6, &u_l));
  EXPECT_NEAR(headingFromLevelledField(u_l, magneticNorthEnu(0.0)), 0.0, 1e-12);
}

TEST(GeomagneticYaw, RejectsWeakOrInvalidFields) {
  Eigen::Vector2d u_l(7, 7);
  EXPECT_FALSE(levelledFieldDirection(Eigen::Vector3d(1e-7, 0, -5e-5), 0, 0, 5e-6, &u_l));
  EXPECT_FALSE(levelledFieldDirection(Eigen::Vector3d(NAN, 0, 0), 0, 0, 5e-6, &u_l));
  EXPECT_FALSE(levelledFieldDirection(Eigen::Vector3d::Zero(), 0, 0, 0.0, &u_l));
  EXPECT_EQ(u_l, Eigen::Vector2d(7, 7));  // untouched on rejection
}

TEST(GeomagneticYaw, AnalyticJacobianMatchesCentralDifferences) {
  const Eigen::Vector2d north = magneticNorthEnu(7 * kDeg);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ang(-M_PI, M_PI);
  for (int i = 0; i < 50; ++i) {
    const double a = ang(rng);
    const Eigen::Vector2d u_l(std::cos(a), std::sin(a));
    const double yaw = ang(rng);
    Eigen::Vector2d J;
    geomagneticYawResidual(yaw, u_l, north, &J);
    auto f = [&](double v) { return Eigen::VectorXd(geomagneticYawResidual(v, u_l, north)); };
    EXPECT_LT((numericDerivative(f, yaw) - J).norm(), 1e-8);
    // Whitened Ceres factor.
    GeomagneticYawFactor factor(u_l, north, 2 * kDeg);
    const double* params[] = {&yaw};
    Eigen::Vector2d r, Jw;
    double* jac[] = {Jw.data()};
    ASSERT_TRUE(factor.Evaluate(params, r.data(), jac));
    EXPECT_LT((r - geomagneticYawResidual(yaw, u_l, north) / (2 * kDeg)).norm(), 1e-9);
    EXPECT_LT((Jw - J / (2 * kDeg)).norm(), 1e-9);
  }
}

}  // namespace
}  // namespace vims
