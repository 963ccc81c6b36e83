#include "vims_pose_graph/pose_graph_factors.h"

#include <cmath>

#include "vims_pose_graph/angles.h"

namespace vims {

RelativePose4Dof relativePose4DofFromPoses(const Eigen::Isometry3d& T_a_i, const Eigen::Isometry3d& T_a_j) {
  const double yaw_i = yawPitchRollFromRotation(T_a_i.linear()).yaw;
  const double yaw_j = yawPitchRollFromRotation(T_a_j.linear()).yaw;
  RelativePose4Dof z;
  z.p_li_j = rotationZ(yaw_i).transpose() * (T_a_j.translation() - T_a_i.translation());
  z.yaw_i_j = wrapAngle(yaw_j - yaw_i);
  return z;
}

RelativePose4Dof relativePose4DofFromRelative(const Eigen::Isometry3d& T_i_j, double pitch_i, double roll_i) {
  // With R_a_i = Rz(yaw_i) R_rp_i:  p_j - p_i = R_a_i t_i_j = Rz(yaw_i) (R_rp_i t_i_j), and
  // R_a_j = Rz(yaw_i) (R_rp_i R_i_j), whose yaw is yaw_i + yaw(R_rp_i R_i_j).
  const Eigen::Matrix3d R_rp_i = rotationFromPitchRoll(pitch_i, roll_i);
  RelativePose4Dof z;
  z.p_li_j = R_rp_i * T_i_j.translation();
  z.yaw_i_j = yawPitchRollFromRotation(R_rp_i * T_i_j.linear()).yaw;
  return z;
}

Eigen::Vector4d relativePose4DofResidual(const Eigen::Vector3d& p_w_i, double yaw_w_i, const Eigen::Vector3d& p_w_j,
                                         double yaw_w_j, const RelativePose4Dof& z,
                                         Eigen::Matrix<double, 4, 3>* d_r_d_p_i, Eigen::Vector4d* d_r_d_yaw_i,
                                         Eigen::Matrix<double, 4, 3>* d_r_d_p_j, Eigen::Vector4d* d_r_d_yaw_j) {
  const Eigen::Matrix3d R_w_li_T = rotationZ(yaw_w_i).transpose();
  const Eigen::Vector3d d = R_w_li_T * (p_w_j - p_w_i);  // j relative to i, in i's levelled frame
  Eigen::Vector4d r;
  r.head<3>() = d - z.p_li_j;
  r[3] = wrapAngle(yaw_w_j - yaw_w_i - z.yaw_i_j);
  if (d_r_d_p_i) {
    d_r_d_p_i->setZero();
    d_r_d_p_i->topRows<3>() = -R_w_li_T;
  }
  if (d_r_d_p_j) {
    d_r_d_p_j->setZero();
    d_r_d_p_j->topRows<3>() = R_w_li_T;
  }
  if (d_r_d_yaw_i) *d_r_d_yaw_i << d.y(), -d.x(), 0.0, -1.0;
  if (d_r_d_yaw_j) *d_r_d_yaw_j << 0.0, 0.0, 0.0, 1.0;
  return r;
}

bool RelativePose4DofFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> p_w_i(parameters[0]);
  const double yaw_w_i = parameters[1][0];
  const Eigen::Map<const Eigen::Vector3d> p_w_j(parameters[2]);
  const double yaw_w_j = parameters[3][0];
  Eigen::Matrix<double, 4, 3> J_p_i, J_p_j;
  Eigen::Vector4d J_yaw_i, J_yaw_j;
  const bool want = jacobians != nullptr;
  const Eigen::Vector4d r =
      relativePose4DofResidual(p_w_i, yaw_w_i, p_w_j, yaw_w_j, measurement_, want ? &J_p_i : nullptr,
                               want ? &J_yaw_i : nullptr, want ? &J_p_j : nullptr, want ? &J_yaw_j : nullptr);
  Eigen::Map<Eigen::Vector4d> r_whitened(residuals);
  r_whitened = sqrt_information_.asDiagonal() * r;
  if (!want) return true;
  // Ceres wants row-major blocks (residuals x parameters).
  using RowMajor43 = Eigen::Matrix<double, 4, 3, Eigen::RowMajor>;
  if (jacobians[0]) {
    Eigen::Map<RowMajor43> J(jacobians[0]);
    J = sqrt_information_.asDiagonal() * J_p_i;
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Vector4d> J(jacobians[1]);
    J = sqrt_information_.cwiseProduct(J_yaw_i);
  }
  if (jacobians[2]) {
    Eigen::Map<RowMajor43> J(jacobians[2]);
    J = sqrt_information_.asDiagonal() * J_p_j;
  }
  if (jacobians[3]) {
    Eigen::Map<Eigen::Vector4d> J(jacobians[3]);
    J = sqrt_information_.cwiseProduct(J_yaw_j);
  }
  return true;
}

Eigen::Vector2d magneticNorthEnu(double declination_rad) {
  // Declination is the angle from true north to magnetic north, east positive; in ENU
  // (x east, y north) that direction is (sin D, cos D).
  return Eigen::Vector2d(std::sin(declination_rad), std::cos(declination_rad));
}

bool levelledFieldDirection(const Eigen::Vector3d& B_b, double pitch, double roll, double min_horizontal_tesla,
                            Eigen::Vector2d* u_l, double* horizontal_tesla) {
  if (!B_b.allFinite() || !std::isfinite(pitch) || !std::isfinite(roll)) return false;
  const Eigen::Vector3d B_l = rotationFromPitchRoll(pitch, roll) * B_b;
  const double horizontal = B_l.head<2>().norm();
  if (horizontal_tesla) *horizontal_tesla = horizontal;
  // A weak horizontal component (near a magnetic pole, or a local disturbance cancelling it)
  // leaves the direction dominated by noise and by roll/pitch errors: no heading from it.
  if (!(horizontal >= min_horizontal_tesla) || horizontal <= 0.0) return false;
  *u_l = B_l.head<2>() / horizontal;
  return true;
}

double headingFromLevelledField(const Eigen::Vector2d& u_l, const Eigen::Vector2d& north_enu) {
  return wrapAngle(std::atan2(north_enu.y(), north_enu.x()) - std::atan2(u_l.y(), u_l.x()));
}

Eigen::Vector2d geomagneticYawResidual(double yaw_w_b, const Eigen::Vector2d& u_l, const Eigen::Vector2d& north_enu,
                                       Eigen::Vector2d* d_r_d_yaw) {
  const double c = std::cos(yaw_w_b), s = std::sin(yaw_w_b);
  const Eigen::Vector2d u_w(c * u_l.x() - s * u_l.y(), s * u_l.x() + c * u_l.y());  // R2(yaw) u_l
  if (d_r_d_yaw) *d_r_d_yaw << -u_w.y(), u_w.x();                                   // d R2/dyaw u = R2 [0 -1; 1 0] u
  return u_w - north_enu;
}

bool GeomagneticYawFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  Eigen::Vector2d J;
  const bool want = jacobians != nullptr && jacobians[0] != nullptr;
  const Eigen::Vector2d r = geomagneticYawResidual(parameters[0][0], u_l_, north_enu_, want ? &J : nullptr);
  Eigen::Map<Eigen::Vector2d> r_whitened(residuals);
  r_whitened = inv_sigma_ * r;
  if (want) {
    Eigen::Map<Eigen::Vector2d> J_whitened(jacobians[0]);
    J_whitened = inv_sigma_ * J;
  }
  return true;
}

bool PoseGraphDepthFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  residuals[0] = inv_sigma_ * (parameters[0][2] + offset_ - parameters[1][0]);
  if (jacobians) {
    if (jacobians[0]) {
      jacobians[0][0] = 0.0;
      jacobians[0][1] = 0.0;
      jacobians[0][2] = inv_sigma_;
    }
    if (jacobians[1]) jacobians[1][0] = -inv_sigma_;
  }
  return std::isfinite(residuals[0]);
}

}  // namespace vims
