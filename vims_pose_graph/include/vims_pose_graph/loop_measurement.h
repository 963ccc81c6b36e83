#pragma once
/// @file loop_measurement.h
/// @brief A PnP-verified loop as the 4-DoF pose graph uses it: the query's position and yaw
/// relative to the match, refined with both keyframes' roll and pitch held at their VIO
/// attitudes, and its covariance from the inliers' geometry and reprojection residuals
/// (docs/pose_graph.md, "Loop edge measurement and information").

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace vims {

/// The inliers of a verified loop: the query's 3D points (its VIO frame) and where the match
/// camera sees them (undistorted normalised coordinates).
struct LoopInlierGeometry {
  std::vector<Eigen::Vector3d> points_odom_query;
  std::vector<Eigen::Vector2d> normalized_match;
};

struct LoopMeasurement {
  /// Pose of the query body in the match body frame, with the query's roll and pitch relative to
  /// the match's levelled frame those of its VIO attitude.
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  /// Covariance of the edge's 4-DoF measurement z = (p_li_j, yaw_i_j) (RelativePose4Dof) [m^2, rad^2].
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();
  /// RMS reprojection residual of the inliers at the refined pose, the 4 fitted degrees of
  /// freedom taken out (normalised image units): the per-point noise the covariance is scaled
  /// with. It holds the pixel noise and the query landmarks' own errors as the match camera
  /// sees them.
  double residual_rms = 0.0;
  int iterations = 0;
};

/// Known-vertical refinement of a PnP loop. The 6-DoF PnP pose trades a tilt for a lateral shift
/// (over a flat seabed both move the image alike), and the graph keeps the VIO's roll and pitch,
/// so the PnP's position, at a tilt that is not the VIO's, is off by about depth x tilt error.
/// Here the query's attitude in the match's levelled frame is Rz(yaw) L_q, L_q = Ry(pitch_q)
/// Rx(roll_q) from its VIO pose, and z = (p_l, yaw) minimises the reprojection error
///   r_i = pi(T_cm_odomq(z) X_i) - u_i,   T_cm_odomq(z) = T_b_c^-1 L_m^-1 [Rz(yaw) L_q, p_l] T_odomq_bq^-1
/// (Gauss-Newton from the PnP pose, L_m = Ry(pitch_m) Rx(roll_m) the match's VIO levelling).
/// Its covariance is s^2 (J^T J)^-1 with s^2 = sum |r_i|^2 / (2N - 4) and J = dr/dz at the optimum.
/// Empty with fewer than 4 inliers, a point behind the camera, a geometry that does not fix all
/// four (J^T J not positive definite) or no convergence.
std::optional<LoopMeasurement> refineLoopMeasurement(const LoopInlierGeometry& inliers,
                                                     const Eigen::Isometry3d& T_match_query_pnp,
                                                     const Eigen::Isometry3d& T_odomq_bq,
                                                     const Eigen::Isometry3d& T_b_c, double pitch_match,
                                                     double roll_match);

}  // namespace vims
