#pragma once
/// @file state_blocks.h
/// @brief Parameter-block layouts of the sliding-window estimator and the pose manifold.
///
/// | block        | ambient (double[]) layout                         | tangent (local) layout     |
/// | ------------ | ------------------------------------------------- | -------------------------- |
/// | pose         | [p_x p_y p_z q_x q_y q_z q_w]  (kPoseSize = 7)     | [dp(3) dtheta(3)] (6)      |
/// | speed-bias   | [v_w_b(3) b_a(3) b_g(3)]       (kSpeedBiasSize=9)  | same, Euclidean            |
/// | feature depth| [lambda]  (1)                                      | Euclidean                  |
/// | time offset  | [td]      (1)                                      | Euclidean                  |
///
/// A pose block T_a_b stores the position p_a_b and the Hamilton quaternion q_a_b (Eigen [x y z w]
/// storage order). Keyframe poses are T_l_b (body in the VIO world frame l); the camera extrinsic
/// is T_b_c. The pose manifold perturbs
///   p' = p + dp                (additive, in the parent frame a)
///   q' = q (x) Exp(dtheta)     (right perturbation: dtheta is a rotation vector in frame b)
/// Every factor's tangent Jacobian is with respect to this [dp, dtheta].

#include <ceres/manifold.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vims {

constexpr int kPoseSize = 7;
constexpr int kPoseTangentSize = 6;
constexpr int kSpeedBiasSize = 9;

/// Read-only views on a pose block.
inline Eigen::Map<const Eigen::Vector3d> posePosition(const double* pose) {
  return Eigen::Map<const Eigen::Vector3d>(pose);
}
inline Eigen::Map<const Eigen::Quaterniond> poseRotation(const double* pose) {
  return Eigen::Map<const Eigen::Quaterniond>(pose + 3);
}
/// Writes p and q (normalised) into a pose block.
inline void setPose(double* pose, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  Eigen::Map<Eigen::Vector3d>{pose} = p;
  Eigen::Map<Eigen::Quaterniond>(pose + 3) = q.normalized();
}
/// The pose block as an isometry (quaternion normalised).
Eigen::Isometry3d poseBlockToIsometry(const double* pose);
/// Writes an isometry into a pose block.
void isometryToPoseBlock(const Eigen::Isometry3d& T, double* pose);

/// Views on a speed-bias block [v_w_b, b_a, b_g].
inline Eigen::Map<const Eigen::Vector3d> sbVelocity(const double* sb) { return Eigen::Map<const Eigen::Vector3d>(sb); }
inline Eigen::Map<const Eigen::Vector3d> sbAccelBias(const double* sb) {
  return Eigen::Map<const Eigen::Vector3d>(sb + 3);
}
inline Eigen::Map<const Eigen::Vector3d> sbGyroBias(const double* sb) {
  return Eigen::Map<const Eigen::Vector3d>(sb + 6);
}

/// The pose manifold: ambient [p(3), q(4, x y z w)], tangent [dp(3), dtheta(3)] with
/// p' = p + dp and q' = q (x) Exp(dtheta). Minus(y, x) = [p_y - p_x, Log(q_x^{-1} q_y)].
///
/// The factors in vims_estimator compute Jacobians in this tangent space and convert them to
/// ambient Jacobians with liftJacobian() (J_ambient = J_tangent * liftJacobian(x)). Because
/// liftJacobian(x) * PlusJacobian(x) = I, Ceres recovers exactly J_tangent. The lifted Jacobian is
/// also correct for any other unit-quaternion manifold (it is the true derivative along every
/// direction tangent to the unit sphere), but MarginalizationInfo assumes this one.
class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseSize; }
  int TangentSize() const override { return kPoseTangentSize; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;  ///< 7x6 row-major
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;  ///< 6x7 row-major

  /// d(y (-) x0)/dy in the ambient coordinates of y, as a 6x7 matrix, valid at any y (not only
  /// y = x0): [I 0; 0 Jr^{-1}(Log(q0^{-1} q_y)) * quaternionLiftJacobian(q_y)]. Used by the
  /// marginalisation prior, whose residual is linear in y (-) x0.
  static Eigen::Matrix<double, 6, 7> minusJacobianAt(const double* y, const double* x0);

  /// Tangent-to-ambient conversion: d(tangent)/d(ambient) at x, a 6x7 matrix [I 0; 0 lift(q)].
  static Eigen::Matrix<double, 6, 7> liftJacobian(const Eigen::Quaterniond& q);
};

/// Converts a tangent-space Jacobian block (rows x 6, for a pose block) to the ambient Jacobian
/// (rows x 7) Ceres expects and writes it row-major into `jacobian` (if non-null).
template <int Rows>
inline void writePoseJacobian(const Eigen::Matrix<double, Rows, kPoseTangentSize>& J_tangent,
                              const Eigen::Quaterniond& q, double* jacobian) {
  if (jacobian == nullptr) return;
  Eigen::Map<Eigen::Matrix<double, Rows, kPoseSize, Eigen::RowMajor>> J(jacobian);
  J = J_tangent * PoseManifold::liftJacobian(q);
}

}  // namespace vims
