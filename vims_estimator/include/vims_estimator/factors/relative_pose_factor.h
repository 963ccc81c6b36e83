#pragma once
/// @file relative_pose_factor.h
/// @brief A 6-dof relative-pose constraint between two pose blocks T_l_bi and T_l_bj (e.g. a
/// relative motion measured by another sensor, or an odometry edge).
///
/// With the measured relative pose (p_ij, q_ij) = T_bi_bj:
///   r_p  = R_i^T (p_j - p_i) - p_ij
///   r_th = Log(q_ij^{-1} (x) q_i^{-1} (x) q_j)     (error in frame b_j)
///   r    = S [r_p; r_th]                           (6 residuals)
/// Tangent Jacobians (q' = q Exp(dtheta)), Jr^{-1} = Jr^{-1}(r_th):
///   dr_p/dp_i = -R_i^T   dr_p/dth_i = [R_i^T (p_j - p_i)]x   dr_p/dp_j = R_i^T
///   dr_th/dth_i = -Jr^{-1} R_j^T R_i                      dr_th/dth_j = Jr^{-1}

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "vims_estimator/factors/pose_prior_factor.h"  // Matrix6d, Vector6d

namespace vims {

/// Unwhitened relative-pose residual and its tangent Jacobians (if non-null).
Vector6d relativePoseResidual(const Eigen::Isometry3d& T_l_bi, const Eigen::Isometry3d& T_l_bj,
                              const Eigen::Vector3d& p_bi_bj, const Eigen::Quaterniond& q_bi_bj,
                              Matrix6d* d_pose_i = nullptr, Matrix6d* d_pose_j = nullptr);

/// Ceres wrapper: parameter blocks [pose_i (7), pose_j (7)], 6 residuals.
class RelativePoseFactor : public ceres::SizedCostFunction<6, 7, 7> {
 public:
  RelativePoseFactor(const Eigen::Vector3d& p_bi_bj, const Eigen::Quaterniond& q_bi_bj,
                     const Matrix6d& sqrt_information);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector3d p_bi_bj_;
  Eigen::Quaterniond q_bi_bj_;
  Matrix6d sqrt_information_;
};

}  // namespace vims
