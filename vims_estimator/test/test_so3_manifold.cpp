// SO(3) helpers and the pose manifold: exp/log, right Jacobians, Plus/Minus and their Jacobians
// against numeric differences.
#include <gtest/gtest.h>

#include "test_utils.h"
#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {
namespace {

TEST(So3, ExpLogRoundTripIncludingSmallAndLargeAngles) {
  std::mt19937 rng(1);
  for (double angle : {0.0, 1e-12, 1e-7, 1e-3, 0.5, 2.0, 3.1}) {
    for (int i = 0; i < 5; ++i) {
      const Eigen::Vector3d theta = angle * test::randomVector(rng, 1.0).normalized();
      const Eigen::Quaterniond q = so3::exp(theta);
      EXPECT_NEAR(q.norm(), 1.0, 1e-15);
      EXPECT_LT((so3::log(q) - theta).norm(), 1e-12 * std::max(1.0, angle)) << angle;
      // Eigen's angle-axis as an independent reference for the exponential.
      const Eigen::Matrix3d R_ref =
          angle > 0 ? Eigen::AngleAxisd(angle, theta.normalized()).toRotationMatrix() : Eigen::Matrix3d::Identity();
      EXPECT_LT((q.toRotationMatrix() - R_ref).norm(), 1e-12);
      // -q is the same rotation.
      EXPECT_LT((so3::log(Eigen::Quaterniond(-q.coeffs())) - theta).norm(), 1e-12 * std::max(1.0, angle));
    }
  }
}

TEST(So3, RightJacobianAndInverseMatchNumericDifferences) {
  std::mt19937 rng(2);
  const double h = 1e-6;
  for (double angle : {1e-8, 1e-3, 0.4, 1.5, 2.8}) {
    const Eigen::Vector3d theta = angle * test::randomVector(rng, 1.0).normalized();
    Eigen::Matrix3d Jr_num, Jr_inv_num;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(k) * h;
      // Exp(theta + e) = Exp(theta) Exp(Jr e)  ->  Jr e = Log(Exp(theta)^-1 Exp(theta + e))
      Jr_num.col(k) = (so3::log(so3::exp(theta).conjugate() * so3::exp(theta + e)) -
                       so3::log(so3::exp(theta).conjugate() * so3::exp(theta - e))) /
                      (2 * h);
      // Log(Exp(theta) Exp(e)) = theta + Jr^-1 e
      Jr_inv_num.col(k) =
          (so3::log(so3::exp(theta) * so3::exp(e)) - so3::log(so3::exp(theta) * so3::exp(-e))) / (2 * h);
    }
    EXPECT_LT((so3::rightJacobian(theta) - Jr_num).cwiseAbs().maxCoeff(), 1e-8) << angle;
    EXPECT_LT((so3::rightJacobianInverse(theta) - Jr_inv_num).cwiseAbs().maxCoeff(), 1e-8) << angle;
    EXPECT_LT((so3::rightJacobian(theta) * so3::rightJacobianInverse(theta) - Eigen::Matrix3d::Identity()).norm(),
              1e-12);
  }
}

TEST(PoseManifold, PlusMinusAreInverseAndJacobiansMatchNumeric) {
  std::mt19937 rng(3);
  const PoseManifold M;
  for (int trial = 0; trial < 10; ++trial) {
    const std::vector<double> x = test::poseBlock(test::randomVector(rng, 5.0), test::randomRotation(rng, 3.0));
    Eigen::Matrix<double, 6, 1> delta;
    delta << test::randomVector(rng, 1.0), test::randomVector(rng, 1.0);
    std::vector<double> y(7);
    M.Plus(x.data(), delta.data(), y.data());
    Eigen::Matrix<double, 6, 1> back;
    M.Minus(y.data(), x.data(), back.data());
    EXPECT_LT((back - delta).norm(), 1e-12);

    // PlusJacobian = d Plus(x, d)/dd at 0.
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> Jp;
    M.PlusJacobian(x.data(), Jp.data());
    const double h = 1e-7;
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> d = Eigen::Matrix<double, 6, 1>::Zero();
      Eigen::Matrix<double, 7, 1> yp, ym;
      d(k) = h;
      M.Plus(x.data(), d.data(), yp.data());
      d(k) = -h;
      M.Plus(x.data(), d.data(), ym.data());
      EXPECT_LT(((yp - ym) / (2 * h) - Jp.col(k)).norm(), 1e-8);
    }
    // MinusJacobian(x) * PlusJacobian(x) = I and liftJacobian is the same matrix.
    Eigen::Matrix<double, 6, 7, Eigen::RowMajor> Jm;
    M.MinusJacobian(x.data(), Jm.data());
    EXPECT_LT((Jm * Jp - Eigen::Matrix<double, 6, 6>::Identity()).norm(), 1e-12);
    EXPECT_LT((PoseManifold::liftJacobian(Eigen::Quaterniond(poseRotation(x.data()))) - Jm).norm(), 1e-15);

    // minusJacobianAt(y, x) * PlusJacobian(y) = d Minus(y (+) d, x)/dd, also away from x.
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> Jpy;
    M.PlusJacobian(y.data(), Jpy.data());
    const Eigen::Matrix<double, 6, 6> analytic = PoseManifold::minusJacobianAt(y.data(), x.data()) * Jpy;
    Eigen::Matrix<double, 6, 6> numeric;
    for (int k = 0; k < 6; ++k) {
      Eigen::Matrix<double, 6, 1> d = Eigen::Matrix<double, 6, 1>::Zero(), mp, mm;
      std::vector<double> yp(7), ym(7);
      d(k) = h;
      M.Plus(y.data(), d.data(), yp.data());
      d(k) = -h;
      M.Plus(y.data(), d.data(), ym.data());
      M.Minus(yp.data(), x.data(), mp.data());
      M.Minus(ym.data(), x.data(), mm.data());
      numeric.col(k) = (mp - mm) / (2 * h);
    }
    EXPECT_LT((analytic - numeric).cwiseAbs().maxCoeff(), 1e-7);
  }
}

}  // namespace
}  // namespace vims
