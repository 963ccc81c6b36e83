#pragma once
/// @file pose_prior_factor.h
/// @brief A 6-dof prior on one pose block T_l_b: anchoring the gauge (position and yaw of the
/// first keyframe) or adding an external pose measurement.
///
/// With the prior mean (p0, q0):
///   r_p  = p - p0
///   r_th = Log(q q0^{-1})                 (rotation error expressed in the parent frame l)
///   r    = S [r_p; r_th]                  (6 residuals, S a 6x6 square-root information)
/// The rotation error lives in frame l, so for a gravity-aligned l its z component is the yaw
/// error (to first order) and its x, y components the roll/pitch errors: a gauge prior on
/// position and yaw only is S = diag(1/sp, 1/sp, 1/sp, 0, 0, 1/syaw) (positionYawSqrtInformation()),
/// which leaves the observable roll and pitch to the IMU.
///
/// Tangent Jacobian (q' = q Exp(dtheta)): q Exp(dth) q0^{-1} = (q q0^{-1}) Exp(R0 dth), so
///   dr_p/dp = I,   dr_th/dth = Jr^{-1}(r_th) R0,   all else zero.

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vims {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

/// Unwhitened prior residual [p - p0; Log(q q0^{-1})] and its 6x6 tangent Jacobian (if non-null).
Vector6d posePriorResidual(const Eigen::Vector3d& p_l_b, const Eigen::Quaterniond& q_l_b, const Eigen::Vector3d& p0_l_b,
                           const Eigen::Quaterniond& q0_l_b, Matrix6d* d_pose = nullptr);

/// Ceres wrapper: one parameter block [pose (7)], 6 residuals.
class PosePriorFactor : public ceres::SizedCostFunction<6, 7> {
 public:
  /// `sqrt_information` may be rank deficient (zero rows leave directions free).
  PosePriorFactor(const Eigen::Vector3d& p0_l_b, const Eigen::Quaterniond& q0_l_b, const Matrix6d& sqrt_information);

  /// diag(1/sigma_position x3, 0, 0, 1/sigma_yaw): fixes position and yaw (the unobservable
  /// directions of VIO), leaves roll and pitch free. Throws std::invalid_argument unless both > 0.
  static Matrix6d positionYawSqrtInformation(double sigma_position, double sigma_yaw);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector3d p0_l_b_;
  Eigen::Quaterniond q0_l_b_;
  Matrix6d sqrt_information_;
};

}  // namespace vims
