#include "vims_pose_graph/angles.h"

#include <cmath>

namespace vims {

Eigen::Matrix3d rotationZ(double yaw) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  Eigen::Matrix3d R;
  R << c, -s, 0, s, c, 0, 0, 0, 1;
  return R;
}

Eigen::Matrix3d rotationFromPitchRoll(double pitch, double roll) {
  return (Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Matrix3d rotationFromYawPitchRoll(double yaw, double pitch, double roll) {
  return rotationZ(yaw) * rotationFromPitchRoll(pitch, roll);
}

YawPitchRoll yawPitchRollFromRotation(const Eigen::Matrix3d& R) {
  // R = Rz(y) Ry(p) Rx(r): first column (cy cp, sy cp, -sp), last row (-sp, cp sr, cp cr).
  YawPitchRoll ypr;
  ypr.yaw = std::atan2(R(1, 0), R(0, 0));
  ypr.pitch = std::atan2(-R(2, 0), std::hypot(R(0, 0), R(1, 0)));
  ypr.roll = std::atan2(R(2, 1), R(2, 2));
  return ypr;
}

bool AngleManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  x_plus_delta[0] = wrapAngle(x[0] + delta[0]);
  return true;
}

bool AngleManifold::PlusJacobian(const double* /*x*/, double* jacobian) const {
  jacobian[0] = 1.0;
  return true;
}

bool AngleManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  y_minus_x[0] = wrapAngle(y[0] - x[0]);
  return true;
}

bool AngleManifold::MinusJacobian(const double* /*x*/, double* jacobian) const {
  jacobian[0] = 1.0;
  return true;
}

}  // namespace vims
