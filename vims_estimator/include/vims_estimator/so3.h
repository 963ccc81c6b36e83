#pragma once
/// @file so3.h
/// @brief SO(3) helpers used by every factor: skew matrix, exponential/logarithm maps between
/// rotation vectors and unit quaternions, and the right Jacobian of SO(3) and its inverse.
///
/// Conventions (docs/factors.md, "Rotations"):
/// - Quaternions are Hamilton, Eigen storage order [x y z w].
/// - A rotation vector theta maps to R = Exp(theta) = exp([theta]x).
/// - The right Jacobian Jr(theta) satisfies Exp(theta + d) ~= Exp(theta) Exp(Jr(theta) d), and
///   Log(Exp(theta) Exp(d)) ~= theta + Jr^{-1}(theta) d for small d.

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vims {
namespace so3 {

/// [v]x, the matrix with [v]x w = v x w.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

/// Unit quaternion of the rotation vector theta (exact; Taylor series near zero).
Eigen::Quaterniond exp(const Eigen::Vector3d& theta);

/// Rotation vector of a unit quaternion, angle in [0, pi]: q and -q give the same result
/// (the shortest rotation). Accurate near zero (no acos of a value close to 1).
Eigen::Vector3d log(const Eigen::Quaterniond& q);

/// Right Jacobian Jr(theta) = I - (1-cos t)/t^2 [theta]x + (t - sin t)/t^3 [theta]x^2, t = |theta|.
Eigen::Matrix3d rightJacobian(const Eigen::Vector3d& theta);

/// Inverse right Jacobian Jr^{-1}(theta) = I + 1/2 [theta]x + (1/t^2 - (1+cos t)/(2 t sin t)) [theta]x^2.
/// Valid for t < 2 pi; log() returns t <= pi, which is where it is used.
Eigen::Matrix3d rightJacobianInverse(const Eigen::Vector3d& theta);

/// d(q (x) Exp(theta)) / d theta at theta = 0, as a 4x3 matrix in [x y z w] row order:
/// rows xyz = 1/2 (w I + [v]x), row w = -1/2 v^T, with q = (v, w). This is the rotation part of
/// PoseManifold::PlusJacobian.
Eigen::Matrix<double, 4, 3> quaternionPlusJacobian(const Eigen::Quaterniond& q);

/// d Log(q^{-1} (x) q') / d q' at q' = q, a 3x4 matrix (columns [x y z w]):
/// 2 [w I - [v]x, -v]. It is the left inverse of quaternionPlusJacobian(q) (their product is I3)
/// and maps any tangent direction of the unit sphere at q to the rotation-vector change it
/// causes. Factors convert their tangent-space Jacobians to ambient (quaternion) Jacobians with it.
Eigen::Matrix<double, 3, 4> quaternionLiftJacobian(const Eigen::Quaterniond& q);

}  // namespace so3
}  // namespace vims
