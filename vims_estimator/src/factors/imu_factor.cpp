#include "vims_estimator/factors/imu_factor.h"

#include <Eigen/Cholesky>
#include <stdexcept>

#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

Eigen::Matrix<double, 15, 1> imuResidual(const ImuPreintegration& pre, const Eigen::Vector3d& g_l, const NavState& xi,
                                         const NavState& xj, ImuResidualJacobians* J) {
  const double T = pre.deltaTime();
  Eigen::Vector3d alpha, beta;
  Eigen::Quaterniond gamma;
  pre.correct(xi.ba, xi.bg, &alpha, &beta, &gamma);

  const Eigen::Matrix3d R_i = xi.q_l_b.toRotationMatrix();
  const Eigen::Matrix3d R_i_T = R_i.transpose();
  const Eigen::Vector3d dp = xj.p_l_b - xi.p_l_b - xi.v_l_b * T - 0.5 * g_l * T * T;
  const Eigen::Vector3d dv = xj.v_l_b - xi.v_l_b - g_l * T;
  const Eigen::Quaterniond q_err = gamma.conjugate() * xi.q_l_b.conjugate() * xj.q_l_b;

  Eigen::Matrix<double, 15, 1> r;
  r.segment<3>(kIdxAlpha) = R_i_T * dp - alpha;
  r.segment<3>(kIdxTheta) = so3::log(q_err);
  r.segment<3>(kIdxBeta) = R_i_T * dv - beta;
  r.segment<3>(kIdxBa) = xj.ba - xi.ba;
  r.segment<3>(kIdxBg) = xj.bg - xi.bg;
  if (J == nullptr) return r;

  const Eigen::Matrix3d I3 = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d Jr_inv = so3::rightJacobianInverse(r.segment<3>(kIdxTheta));
  const Eigen::Matrix3d R_j = xj.q_l_b.toRotationMatrix();
  // gamma(b_g) = gamma_lin Exp(phi), phi = dtheta/dbg (b_g - b_g,lin); perturbing b_g by e moves
  // it to gamma(b_g) Exp(Jr(phi) dtheta/dbg e), which rotates q_err by Exp(-E^T Jr(phi) dtheta/dbg e).
  const Eigen::Vector3d phi = pre.dThetaDbg() * (xi.bg - pre.linearizedGyroBias());
  const Eigen::Matrix3d E = q_err.toRotationMatrix();

  J->d_pose_i.setZero();
  J->d_pose_i.block<3, 3>(kIdxAlpha, 0) = -R_i_T;
  J->d_pose_i.block<3, 3>(kIdxAlpha, 3) = so3::skew(R_i_T * dp);
  J->d_pose_i.block<3, 3>(kIdxTheta, 3) = -Jr_inv * R_j.transpose() * R_i;
  J->d_pose_i.block<3, 3>(kIdxBeta, 3) = so3::skew(R_i_T * dv);

  J->d_speed_bias_i.setZero();
  J->d_speed_bias_i.block<3, 3>(kIdxAlpha, 0) = -R_i_T * T;
  J->d_speed_bias_i.block<3, 3>(kIdxAlpha, 3) = -pre.dAlphaDba();
  J->d_speed_bias_i.block<3, 3>(kIdxAlpha, 6) = -pre.dAlphaDbg();
  J->d_speed_bias_i.block<3, 3>(kIdxTheta, 6) = -Jr_inv * E.transpose() * so3::rightJacobian(phi) * pre.dThetaDbg();
  J->d_speed_bias_i.block<3, 3>(kIdxBeta, 0) = -R_i_T;
  J->d_speed_bias_i.block<3, 3>(kIdxBeta, 3) = -pre.dBetaDba();
  J->d_speed_bias_i.block<3, 3>(kIdxBeta, 6) = -pre.dBetaDbg();
  J->d_speed_bias_i.block<3, 3>(kIdxBa, 3) = -I3;
  J->d_speed_bias_i.block<3, 3>(kIdxBg, 6) = -I3;

  J->d_pose_j.setZero();
  J->d_pose_j.block<3, 3>(kIdxAlpha, 0) = R_i_T;
  J->d_pose_j.block<3, 3>(kIdxTheta, 3) = Jr_inv;

  J->d_speed_bias_j.setZero();
  J->d_speed_bias_j.block<3, 3>(kIdxBeta, 0) = R_i_T;
  J->d_speed_bias_j.block<3, 3>(kIdxBa, 3) = I3;
  J->d_speed_bias_j.block<3, 3>(kIdxBg, 6) = I3;
  return r;
}

Eigen::Matrix<double, 15, 15> imuSqrtInformation(const Matrix15d& covariance) {
  const Matrix15d P = 0.5 * (covariance + covariance.transpose());
  const Matrix15d information = P.llt().solve(Matrix15d::Identity());
  const Matrix15d symmetric_information = 0.5 * (information + information.transpose());
  return symmetric_information.llt().matrixL().transpose();
}

ImuFactor::ImuFactor(std::shared_ptr<const ImuPreintegration> preintegration, const Eigen::Vector3d& g_l)
    : preintegration_(std::move(preintegration)), g_l_(g_l) {
  if (!preintegration_) throw std::invalid_argument("ImuFactor: null preintegration");
  if (preintegration_->numSteps() < 1) throw std::invalid_argument("ImuFactor: empty preintegration");
}

bool ImuFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  NavState xi, xj;
  xi.p_l_b = posePosition(parameters[0]);
  xi.q_l_b = poseRotation(parameters[0]);
  xi.v_l_b = sbVelocity(parameters[1]);
  xi.ba = sbAccelBias(parameters[1]);
  xi.bg = sbGyroBias(parameters[1]);
  xj.p_l_b = posePosition(parameters[2]);
  xj.q_l_b = poseRotation(parameters[2]);
  xj.v_l_b = sbVelocity(parameters[3]);
  xj.ba = sbAccelBias(parameters[3]);
  xj.bg = sbGyroBias(parameters[3]);

  const bool want_jacobians = jacobians != nullptr;
  ImuResidualJacobians J;
  const Eigen::Matrix<double, 15, 1> r = imuResidual(*preintegration_, g_l_, xi, xj, want_jacobians ? &J : nullptr);
  const Eigen::Matrix<double, 15, 15> S = imuSqrtInformation(preintegration_->covariance());
  Eigen::Map<Eigen::Matrix<double, 15, 1>>{residuals} = S * r;
  if (!want_jacobians) return true;

  writePoseJacobian<15>(S * J.d_pose_i, xi.q_l_b, jacobians[0]);
  if (jacobians[1]) Eigen::Map<Eigen::Matrix<double, 15, 9, Eigen::RowMajor>>{jacobians[1]} = S * J.d_speed_bias_i;
  writePoseJacobian<15>(S * J.d_pose_j, xj.q_l_b, jacobians[2]);
  if (jacobians[3]) Eigen::Map<Eigen::Matrix<double, 15, 9, Eigen::RowMajor>>{jacobians[3]} = S * J.d_speed_bias_j;
  return true;
}

}  // namespace vims
