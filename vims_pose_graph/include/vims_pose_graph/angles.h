#pragma once
/// @file angles.h
/// @brief Yaw-pitch-roll helpers for the 4-DoF pose graph and a ceres::Manifold for a yaw angle.
///
/// Attitude is split as R_w_b = Rz(yaw) * Ry(pitch) * Rx(roll) (intrinsic Z-Y-X, the usual
/// aerospace convention in ENU/FLU). The pose graph optimises yaw only; roll and pitch are
/// observable from gravity in the VIO and are held fixed.

#include <ceres/manifold.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "vims_common/wrap_angle.h"  // wrapAngle, used with the yaws below

namespace vims {

/// Rotation about +z by `yaw`.
Eigen::Matrix3d rotationZ(double yaw);
/// Rz(yaw) * Ry(pitch) * Rx(roll).
Eigen::Matrix3d rotationFromYawPitchRoll(double yaw, double pitch, double roll);
/// Ry(pitch) * Rx(roll): the body attitude with the heading removed ("levelled" frame -> body).
Eigen::Matrix3d rotationFromPitchRoll(double pitch, double roll);

struct YawPitchRoll {
  double yaw = 0.0;    ///< [rad], (-pi, pi]
  double pitch = 0.0;  ///< [rad], [-pi/2, pi/2]
  double roll = 0.0;   ///< [rad], (-pi, pi]
};
/// Decomposes R = Rz(yaw) Ry(pitch) Rx(roll). Near pitch = +-90 deg yaw and roll are not
/// separable (not a state an AUV flies in); the split there is arbitrary but consistent.
YawPitchRoll yawPitchRollFromRotation(const Eigen::Matrix3d& R);

/// A yaw angle as a 1-D manifold: Plus(x, dx) = wrap(x + dx), Minus(y, x) = wrap(y - x).
/// Keeps optimised yaws in [-pi, pi] and makes a step across +-pi a small step. Both Jacobians
/// are 1 (the wrap is locally the identity).
class AngleManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 1; }
  int TangentSize() const override { return 1; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

}  // namespace vims
