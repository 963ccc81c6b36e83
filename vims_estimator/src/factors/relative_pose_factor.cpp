#include "vims_estimator/factors/relative_pose_factor.h"

#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

Vector6d relativePoseResidual(const Eigen::Isometry3d& T_l_bi, const Eigen::Isometry3d& T_l_bj,
                              const Eigen::Vector3d& p_bi_bj, const Eigen::Quaterniond& q_bi_bj, Matrix6d* d_pose_i,
                              Matrix6d* d_pose_j) {
  const Eigen::Matrix3d R_i = T_l_bi.linear();
  const Eigen::Matrix3d R_j = T_l_bj.linear();
  const Eigen::Vector3d dp_i = R_i.transpose() * (T_l_bj.translation() - T_l_bi.translation());
  const Eigen::Quaterniond q_i(R_i), q_j(R_j);

  Vector6d r;
  r.head<3>() = dp_i - p_bi_bj;
  r.tail<3>() = so3::log(q_bi_bj.conjugate() * q_i.conjugate() * q_j);
  if (d_pose_i == nullptr && d_pose_j == nullptr) return r;

  const Eigen::Matrix3d Jr_inv = so3::rightJacobianInverse(r.tail<3>());
  if (d_pose_i) {
    d_pose_i->setZero();
    d_pose_i->topLeftCorner<3, 3>() = -R_i.transpose();
    d_pose_i->topRightCorner<3, 3>() = so3::skew(dp_i);
    d_pose_i->bottomRightCorner<3, 3>() = -Jr_inv * R_j.transpose() * R_i;
  }
  if (d_pose_j) {
    d_pose_j->setZero();
    d_pose_j->topLeftCorner<3, 3>() = R_i.transpose();
    d_pose_j->bottomRightCorner<3, 3>() = Jr_inv;
  }
  return r;
}

RelativePoseFactor::RelativePoseFactor(const Eigen::Vector3d& p_bi_bj, const Eigen::Quaterniond& q_bi_bj,
                                       const Matrix6d& sqrt_information)
    : p_bi_bj_(p_bi_bj), q_bi_bj_(q_bi_bj.normalized()), sqrt_information_(sqrt_information) {}

bool RelativePoseFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  Matrix6d J_i, J_j;
  const Vector6d r = relativePoseResidual(poseBlockToIsometry(parameters[0]), poseBlockToIsometry(parameters[1]),
                                          p_bi_bj_, q_bi_bj_, jacobians ? &J_i : nullptr, jacobians ? &J_j : nullptr);
  Eigen::Map<Vector6d>{residuals} = sqrt_information_ * r;
  if (!jacobians) return true;
  writePoseJacobian<6>(sqrt_information_ * J_i, Eigen::Quaterniond(poseRotation(parameters[0])), jacobians[0]);
  writePoseJacobian<6>(sqrt_information_ * J_j, Eigen::Quaterniond(poseRotation(parameters[1])), jacobians[1]);
  return true;
}

}  // namespace vims
