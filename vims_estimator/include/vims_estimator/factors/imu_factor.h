#pragma once
/// @file imu_factor.h
/// @brief The IMU preintegration factor between keyframes i and j (15 residuals).
///
/// States: pose_i = T_l_bi, speed-bias_i = [v_l_bi, b_a,i, b_g,i], pose_j, speed-bias_j
/// (layouts in state_blocks.h). With T = t_j - t_i, g_l = [0, 0, -g] and the bias-corrected
/// preintegration (alpha, beta, gamma) = correct(b_a,i, b_g,i) (imu_preintegration.h):
///
///   r_p  = R_i^T (p_j - p_i - v_i T - 1/2 g_l T^2) - alpha
///   r_th = Log(gamma^{-1} (x) q_i^{-1} (x) q_j)
///   r_v  = R_i^T (v_j - v_i - g_l T) - beta
///   r_ba = b_a,j - b_a,i
///   r_bg = b_g,j - b_g,i
///
/// ordered [r_p, r_th, r_v, r_ba, r_bg] like the preintegration error state, and whitened by
/// S = chol(P^{-1})^T (P the preintegration covariance), so that |S r|^2 = r^T P^{-1} r.
///
/// Tangent Jacobians (pose tangent [dp, dtheta], q' = q Exp(dtheta); Jr^{-1} = Jr^{-1}(r_th);
/// E = R(gamma^{-1} q_i^{-1} q_j); phi = dtheta/dbg (b_g,i - b_g,lin)):
///   dr_p/dp_i = -R_i^T            dr_p/dth_i = [R_i^T (p_j - p_i - v_i T - 1/2 g T^2)]x
///   dr_th/dth_i = -Jr^{-1} R_j^T R_i
///   dr_v/dth_i = [R_i^T (v_j - v_i - g T)]x
///   dr_p/dv_i = -R_i^T T   dr_p/dba_i = -dalpha/dba   dr_p/dbg_i = -dalpha/dbg
///   dr_th/dbg_i = -Jr^{-1} E^T Jr(phi) dtheta/dbg
///   dr_v/dv_i = -R_i^T     dr_v/dba_i = -dbeta/dba    dr_v/dbg_i = -dbeta/dbg
///   dr_ba/dba_i = -I       dr_bg/dbg_i = -I
///   dr_p/dp_j = R_i^T      dr_th/dth_j = Jr^{-1}
///   dr_v/dv_j = R_i^T      dr_ba/dba_j = I      dr_bg/dbg_j = I
/// Derivations: docs/factors.md, "IMU factor".

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>

#include "vims_estimator/imu_preintegration.h"

namespace vims {

/// Navigation state of one keyframe in the VIO frame l (plain values for the pure functions).
struct NavState {
  Eigen::Vector3d p_l_b = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_l_b = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_l_b = Eigen::Vector3d::Zero();
  Eigen::Vector3d ba = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
};

/// Tangent-space Jacobians of the unwhitened IMU residual.
struct ImuResidualJacobians {
  Eigen::Matrix<double, 15, 6> d_pose_i;
  Eigen::Matrix<double, 15, 9> d_speed_bias_i;
  Eigen::Matrix<double, 15, 6> d_pose_j;
  Eigen::Matrix<double, 15, 9> d_speed_bias_j;
};

/// The unwhitened IMU residual r(x_i, x_j) (file comment); fills `jacobians` if non-null.
Eigen::Matrix<double, 15, 1> imuResidual(const ImuPreintegration& preintegration, const Eigen::Vector3d& g_l,
                                         const NavState& state_i, const NavState& state_j,
                                         ImuResidualJacobians* jacobians = nullptr);

/// Upper-triangular S with S^T S = covariance^{-1} (S = L^T, L L^T = covariance^{-1}).
Eigen::Matrix<double, 15, 15> imuSqrtInformation(const Matrix15d& covariance);

/// Ceres wrapper: parameter blocks [pose_i (7), speed_bias_i (9), pose_j (7), speed_bias_j (9)].
///
/// It keeps a shared pointer to the preintegration: the caller may repropagate it between solves
/// (ImuPreintegration::repropagateIfNeeded); whitening is recomputed from its current covariance
/// at every evaluation.
class ImuFactor : public ceres::SizedCostFunction<15, 7, 9, 7, 9> {
 public:
  /// `g_l` is the gravity vector in the VIO frame, [0, 0, -g].
  ImuFactor(std::shared_ptr<const ImuPreintegration> preintegration, const Eigen::Vector3d& g_l);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

  const ImuPreintegration& preintegration() const { return *preintegration_; }

 private:
  std::shared_ptr<const ImuPreintegration> preintegration_;
  Eigen::Vector3d g_l_;
};

}  // namespace vims
