#pragma once
/// @file pose_graph_factors.h
/// @brief Residuals of the 4-DoF global pose graph (docs/pose_graph.md).
///
/// The math lives in pure functions with optional Jacobian outputs (unwhitened residuals); the
/// Ceres classes only call them and whiten with the square-root information. Parameter blocks
/// of a node: p_w_b (3, world position of the body) and yaw_w_b (1, world yaw of the body).

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vims {

// ---------------------------------------------------------------------------------------------
// Relative pose (odometry and loop edges)
// ---------------------------------------------------------------------------------------------

/// A 4-DoF relative pose of node j seen from node i: the position of j relative to i expressed
/// in i's levelled frame (the world frame rotated by i's yaw only), and the yaw difference.
/// Both are invariant to the 4-DoF (yaw + translation) ambiguity between the VIO frame and the
/// world frame, so VIO measurements can constrain world poses directly.
struct RelativePose4Dof {
  Eigen::Vector3d p_li_j = Eigen::Vector3d::Zero();  ///< Rz(yaw_i)^T (p_j - p_i) [m]
  double yaw_i_j = 0.0;                              ///< wrap(yaw_j - yaw_i) [rad]
};

/// From two poses in one gravity-aligned frame `a` (e.g. the VIO frame: T_odom_i, T_odom_j).
RelativePose4Dof relativePose4DofFromPoses(const Eigen::Isometry3d& T_a_i, const Eigen::Isometry3d& T_a_j);

/// From a 6-DoF relative pose T_i_j (pose of j in body frame i; e.g. a loop measurement
/// T_match_query from PnP) and the pitch/roll of node i (from the VIO):
///   p_li_j = Ry(pitch_i) Rx(roll_i) t_i_j,   yaw_i_j = yaw(Ry(pitch_i) Rx(roll_i) R_i_j).
/// j's own pitch/roll implied by T_i_j are dropped (the 4-DoF graph keeps the VIO's).
RelativePose4Dof relativePose4DofFromRelative(const Eigen::Isometry3d& T_i_j, double pitch_i, double roll_i);

/// Unwhitened residual of a relative-pose edge i -> j:
///   r[0:3] = Rz(yaw_i)^T (p_j - p_i) - z.p_li_j
///   r[3]   = wrap(yaw_j - yaw_i - z.yaw_i_j)
/// Jacobians (optional, column-major Eigen): with d = Rz(yaw_i)^T (p_j - p_i),
///   dr/dp_i = [-Rz^T; 0],  dr/dp_j = [Rz^T; 0],
///   dr/dyaw_i = [d_y, -d_x, 0, -1]^T,  dr/dyaw_j = [0, 0, 0, 1]^T
/// (d Rz(y)^T / dy = -[e_z]x Rz(y)^T, and -e_z x d = (d_y, -d_x, 0)).
Eigen::Vector4d relativePose4DofResidual(const Eigen::Vector3d& p_w_i, double yaw_w_i, const Eigen::Vector3d& p_w_j,
                                         double yaw_w_j, const RelativePose4Dof& z,
                                         Eigen::Matrix<double, 4, 3>* d_r_d_p_i = nullptr,
                                         Eigen::Vector4d* d_r_d_yaw_i = nullptr,
                                         Eigen::Matrix<double, 4, 3>* d_r_d_p_j = nullptr,
                                         Eigen::Vector4d* d_r_d_yaw_j = nullptr);

/// Ceres wrapper. Parameter blocks: p_w_i (3), yaw_w_i (1), p_w_j (3), yaw_w_j (1).
/// Residual: diag(sqrt_information) * relativePose4DofResidual(...).
class RelativePose4DofFactor final : public ceres::SizedCostFunction<4, 3, 1, 3, 1> {
 public:
  /// `sqrt_information` = (1/sigma_x, 1/sigma_y, 1/sigma_z, 1/sigma_yaw).
  RelativePose4DofFactor(const RelativePose4Dof& measurement, const Eigen::Vector4d& sqrt_information)
      : measurement_(measurement), sqrt_information_(sqrt_information) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  RelativePose4Dof measurement_;
  Eigen::Vector4d sqrt_information_;
};

// ---------------------------------------------------------------------------------------------
// Geomagnetic yaw
// ---------------------------------------------------------------------------------------------

/// Unit vector of magnetic north in ENU for a declination D (east positive): (sin D, cos D).
Eigen::Vector2d magneticNorthEnu(double declination_rad);

/// The horizontal direction of a (low-passed, geomagnetic) field B_b measured in the body frame,
/// expressed in the levelled frame l (world axes rotated by the body yaw):
///   B_l = Ry(pitch) Rx(roll) B_b,  u_l = B_l.xy / |B_l.xy|.
/// Returns false (outputs untouched) if B_b is not finite or |B_l.xy| < min_horizontal_tesla;
/// `horizontal_tesla` (optional) receives |B_l.xy|.
bool levelledFieldDirection(const Eigen::Vector3d& B_b, double pitch, double roll, double min_horizontal_tesla,
                            Eigen::Vector2d* u_l, double* horizontal_tesla = nullptr);

/// The heading measured by the field: the yaw psi with Rz(psi) u_l = north_enu, i.e.
///   psi = wrap(atan2(n_y, n_x) - atan2(u_y, u_x)).
double headingFromLevelledField(const Eigen::Vector2d& u_l, const Eigen::Vector2d& north_enu);

/// Unwhitened geomagnetic yaw residual, in vector (chordal) form so no angle wrap is needed:
///   r = R2(yaw) u_l - n,   R2 the 2-D rotation, n = magneticNorthEnu(D).
/// |r| = 2 |sin((yaw - psi_meas) / 2)|, i.e. |yaw - psi_meas| for small errors, so a sigma in
/// radians whitens it; it saturates at 2 for a heading 180 deg off, which also bounds the
/// influence of a grossly disturbed measurement. Jacobian: dr/dyaw = (-(R2 u)_y, (R2 u)_x).
Eigen::Vector2d geomagneticYawResidual(double yaw_w_b, const Eigen::Vector2d& u_l, const Eigen::Vector2d& north_enu,
                                       Eigen::Vector2d* d_r_d_yaw = nullptr);

/// Ceres wrapper. Parameter block: yaw_w_b (1). Residual: geomagneticYawResidual / sigma_yaw.
class GeomagneticYawFactor final : public ceres::SizedCostFunction<2, 1> {
 public:
  GeomagneticYawFactor(const Eigen::Vector2d& u_l, const Eigen::Vector2d& north_enu, double sigma_yaw_rad)
      : u_l_(u_l), north_enu_(north_enu), inv_sigma_(1.0 / sigma_yaw_rad) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector2d u_l_;
  Eigen::Vector2d north_enu_;
  double inv_sigma_;
};

/// Pressure depth of a node: r = (z + c + d - z_s) / sigma with the node's world position p (z its
/// third component), the port offset c and the depth d constant, the surface height z_s a state.
/// Blocks [p_w_b (3), z_s (1)]; dr/dp = (0, 0, 1/sigma), dr/dz_s = -1/sigma.
class PoseGraphDepthFactor final : public ceres::SizedCostFunction<1, 3, 1> {
 public:
  PoseGraphDepthFactor(double depth_m, double port_offset_z, double sigma_m)
      : offset_(port_offset_z + depth_m), inv_sigma_(1.0 / sigma_m) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  double offset_;
  double inv_sigma_;
};

}  // namespace vims
