#include "vims_estimator/state_blocks.h"

#include "vims_estimator/so3.h"

namespace vims {

Eigen::Isometry3d poseBlockToIsometry(const double* pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(poseRotation(pose)).normalized().toRotationMatrix();
  T.translation() = posePosition(pose);
  return T;
}

void isometryToPoseBlock(const Eigen::Isometry3d& T, double* pose) {
  setPose(pose, T.translation(), Eigen::Quaterniond(T.linear()));
}

bool PoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Eigen::Map<const Eigen::Vector3d> dp(delta);
  const Eigen::Map<const Eigen::Vector3d> dtheta(delta + 3);
  setPose(x_plus_delta, posePosition(x) + dp, poseRotation(x) * so3::exp(dtheta));
  return true;
}

bool PoseManifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, kPoseSize, kPoseTangentSize, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topLeftCorner<3, 3>().setIdentity();
  J.bottomRightCorner<4, 3>() = so3::quaternionPlusJacobian(Eigen::Quaterniond(poseRotation(x)));
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  Eigen::Map<Eigen::Vector3d>{y_minus_x} = posePosition(y) - posePosition(x);
  Eigen::Map<Eigen::Vector3d>(y_minus_x + 3) = so3::log(poseRotation(x).conjugate() * poseRotation(y));
  return true;
}

bool PoseManifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, kPoseTangentSize, kPoseSize, Eigen::RowMajor>> J(jacobian);
  J = liftJacobian(Eigen::Quaterniond(poseRotation(x)));
  return true;
}

Eigen::Matrix<double, 6, 7> PoseManifold::liftJacobian(const Eigen::Quaterniond& q) {
  Eigen::Matrix<double, 6, 7> J = Eigen::Matrix<double, 6, 7>::Zero();
  J.topLeftCorner<3, 3>().setIdentity();
  J.bottomRightCorner<3, 4>() = so3::quaternionLiftJacobian(q);
  return J;
}

Eigen::Matrix<double, 6, 7> PoseManifold::minusJacobianAt(const double* y, const double* x0) {
  const Eigen::Quaterniond q_y(poseRotation(y));
  const Eigen::Vector3d phi = so3::log(poseRotation(x0).conjugate() * q_y);
  // Log(q0^{-1} q_y Exp(d)) ~= phi + Jr^{-1}(phi) d, and d = lift(q_y) dq_y for tangent dq_y.
  Eigen::Matrix<double, 6, 7> J = Eigen::Matrix<double, 6, 7>::Zero();
  J.topLeftCorner<3, 3>().setIdentity();
  J.bottomRightCorner<3, 4>() = so3::rightJacobianInverse(phi) * so3::quaternionLiftJacobian(q_y);
  return J;
}

}  // namespace vims
