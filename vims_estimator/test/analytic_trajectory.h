#pragma once
/// @file analytic_trajectory.h
/// @brief A smooth body trajectory with closed-form position, velocity, acceleration, attitude
/// and body angular rate, and the ideal IMU samples it produces (test-only).
///
///   p(t) = p0 + v0 t + A .* sin(w t + phase)          (per axis)
///   R(t) = Rz(yaw) Ry(pitch) Rx(roll)                 (ZYX Euler, body FLU in world ENU)
///   roll = r_a sin(r_w t), pitch = p_a sin(p_w t), yaw = y0 + y_rate t + y_a sin(y_w t)
///   omega_b = [droll - dyaw sin(pitch);
///              dpitch cos(roll) + dyaw cos(pitch) sin(roll);
///              -dpitch sin(roll) + dyaw cos(pitch) cos(roll)]      (ZYX Euler body rates)
///   f_b = R^T (a_w - g_w),  g_w = [0, 0, -g]                        (specific force)

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

#include "vims_common/sensor_data.h"

namespace vims {
namespace test {

struct AnalyticTrajectory {
  Eigen::Vector3d p0 = Eigen::Vector3d(1.0, -2.0, 3.0);
  Eigen::Vector3d v0 = Eigen::Vector3d(0.3, 0.1, -0.05);
  Eigen::Vector3d amplitude = Eigen::Vector3d(0.8, 0.5, 0.2);
  Eigen::Vector3d omega = Eigen::Vector3d(1.1, 0.7, 1.9);
  Eigen::Vector3d phase = Eigen::Vector3d(0.2, 1.0, -0.4);
  double roll_a = 0.25, roll_w = 1.3;
  double pitch_a = 0.2, pitch_w = 0.9;
  double yaw0 = 0.4, yaw_rate = 0.3, yaw_a = 0.5, yaw_w = 0.8;
  double gravity = 9.81;

  /// Constant velocity, constant attitude rate about z: no acceleration, so an IMU cannot tell
  /// the speed.
  static AnalyticTrajectory constantVelocity(const Eigen::Vector3d& p0, const Eigen::Vector3d& v0, double yaw0,
                                             double yaw_rate) {
    AnalyticTrajectory t;
    t.p0 = p0;
    t.v0 = v0;
    t.amplitude.setZero();
    t.roll_a = t.pitch_a = t.yaw_a = 0.0;
    t.yaw0 = yaw0;
    t.yaw_rate = yaw_rate;
    return t;
  }

  Eigen::Vector3d gravityWorld() const { return Eigen::Vector3d(0.0, 0.0, -gravity); }

  Eigen::Vector3d position(double t) const {
    Eigen::Vector3d p = p0 + v0 * t;
    for (int i = 0; i < 3; ++i) p(i) += amplitude(i) * std::sin(omega(i) * t + phase(i));
    return p;
  }
  Eigen::Vector3d velocity(double t) const {
    Eigen::Vector3d v = v0;
    for (int i = 0; i < 3; ++i) v(i) += amplitude(i) * omega(i) * std::cos(omega(i) * t + phase(i));
    return v;
  }
  Eigen::Vector3d acceleration(double t) const {
    Eigen::Vector3d a;
    for (int i = 0; i < 3; ++i) a(i) = -amplitude(i) * omega(i) * omega(i) * std::sin(omega(i) * t + phase(i));
    return a;
  }

  void euler(double t, double* roll, double* pitch, double* yaw, double* droll, double* dpitch, double* dyaw) const {
    *roll = roll_a * std::sin(roll_w * t);
    *pitch = pitch_a * std::sin(pitch_w * t);
    *yaw = yaw0 + yaw_rate * t + yaw_a * std::sin(yaw_w * t);
    *droll = roll_a * roll_w * std::cos(roll_w * t);
    *dpitch = pitch_a * pitch_w * std::cos(pitch_w * t);
    *dyaw = yaw_rate + yaw_a * yaw_w * std::cos(yaw_w * t);
  }

  Eigen::Quaterniond rotation(double t) const {
    double r, p, y, dr, dp, dy;
    euler(t, &r, &p, &y, &dr, &dp, &dy);
    return Eigen::Quaterniond(Eigen::AngleAxisd(y, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(p, Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(r, Eigen::Vector3d::UnitX()));
  }

  Eigen::Vector3d angularRateBody(double t) const {
    double r, p, y, dr, dp, dy;
    euler(t, &r, &p, &y, &dr, &dp, &dy);
    return Eigen::Vector3d(dr - dy * std::sin(p), dp * std::cos(r) + dy * std::cos(p) * std::sin(r),
                           -dp * std::sin(r) + dy * std::cos(p) * std::cos(r));
  }

  Eigen::Isometry3d pose(double t) const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = rotation(t).toRotationMatrix();
    T.translation() = position(t);
    return T;
  }

  /// Ideal (noise- and bias-free) IMU sample at t.
  ImuSample imu(double t) const {
    ImuSample s;
    s.t = t;
    s.gyro = angularRateBody(t);
    s.accel = rotation(t).conjugate() * (acceleration(t) - gravityWorld());
    return s;
  }
};

}  // namespace test
}  // namespace vims
