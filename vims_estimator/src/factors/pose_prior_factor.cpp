#include "vims_estimator/factors/pose_prior_factor.h"

#include <stdexcept>

#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

Vector6d posePriorResidual(const Eigen::Vector3d& p_l_b, const Eigen::Quaterniond& q_l_b, const Eigen::Vector3d& p0_l_b,
                           const Eigen::Quaterniond& q0_l_b, Matrix6d* d_pose) {
  Vector6d r;
  r.head<3>() = p_l_b - p0_l_b;
  r.tail<3>() = so3::log(q_l_b * q0_l_b.conjugate());
  if (d_pose) {
    d_pose->setZero();
    d_pose->topLeftCorner<3, 3>().setIdentity();
    d_pose->bottomRightCorner<3, 3>() = so3::rightJacobianInverse(r.tail<3>()) * q0_l_b.toRotationMatrix();
  }
  return r;
}

PosePriorFactor::PosePriorFactor(const Eigen::Vector3d& p0_l_b, const Eigen::Quaterniond& q0_l_b,
                                 const Matrix6d& sqrt_information)
    : p0_l_b_(p0_l_b), q0_l_b_(q0_l_b.normalized()), sqrt_information_(sqrt_information) {}

Matrix6d PosePriorFactor::positionYawSqrtInformation(double sigma_position, double sigma_yaw) {
  if (!(sigma_position > 0.0 && sigma_yaw > 0.0)) {
    throw std::invalid_argument("PosePriorFactor::positionYawSqrtInformation: sigmas must be > 0");
  }
  Vector6d d;
  d << 1.0 / sigma_position, 1.0 / sigma_position, 1.0 / sigma_position, 0.0, 0.0, 1.0 / sigma_yaw;
  return d.asDiagonal();
}

bool PosePriorFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Quaterniond q(poseRotation(parameters[0]));
  Matrix6d J;
  const Vector6d r =
      posePriorResidual(posePosition(parameters[0]), q.normalized(), p0_l_b_, q0_l_b_, jacobians ? &J : nullptr);
  Eigen::Map<Vector6d>{residuals} = sqrt_information_ * r;
  if (jacobians) writePoseJacobian<6>(sqrt_information_ * J, q, jacobians[0]);
  return true;
}

}  // namespace vims
