#pragma once
/// @file pressure_depth_factor.h
/// @brief The pressure depth factor and the seabed gradient's random walk and prior.
///
/// Pressure depth (1 residual). The pressure sensor measures the depth d_k of its port below the
/// water surface; the surface is a level plane at height z_s in the gravity-aligned frame l (a
/// state: frame l's origin is arbitrary, and a wrong atmospheric offset in the YAML only moves
/// z_s). Blocks [pose_k (7), z_s (1)]; constant: the port's position p_bp in the body.
///
///   r = (p_k + R_k p_bp)_z + d_k - z_s
///   dr/dp_k = e_z^T      dr/dth_k = -e_z^T R_k [p_bp]x      dr/dz_s = -1
///
/// sigma is the depth noise (the YAML's noise_std_pa / (rho g), floored). Unlike the sonar factor
/// it pins the keyframe's absolute height, so the window's height no longer drifts along its
/// unobservable direction, and with the sonar (or the carried seabed) it fixes the altitude.
///
/// Seabed gradient random walk (2 residuals), blocks [g_i (2), g_j (2)]: r = (g_j - g_i) / sigma,
/// sigma^2 = slope_random_walk^2 * D_ij + slope_step_std^2 with D_ij the horizontal distance
/// between the keyframes. Gradient prior (2), block [g]: r = (g - g0) / sigma.

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vims {

/// Tangent-space Jacobians of the unwhitened pressure depth residual.
struct PressureDepthJacobians {
  Eigen::Matrix<double, 1, 6> d_pose;
  double d_surface = -1.0;
};

/// r = (p_k + R_k p_bp)_z + depth - surface_z; Jacobians if non-null.
double pressureDepthResidual(double depth, const Eigen::Vector3d& p_bp, const Eigen::Isometry3d& T_l_bk,
                             double surface_z, PressureDepthJacobians* jacobians = nullptr);

/// Ceres wrapper: blocks [pose_k (7), surface_z (1)]; returns r / sigma. Throws
/// std::invalid_argument if depth is not finite or sigma is not > 0.
class PressureDepthFactor : public ceres::SizedCostFunction<1, 7, 1> {
 public:
  PressureDepthFactor(double depth, const Eigen::Vector3d& p_bp, double sigma);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  double depth_;
  Eigen::Vector3d p_bp_;
  double inv_sigma_;
};

/// r = (g_j - g_i) / sigma; blocks [g_i (2), g_j (2)]. Throws if sigma is not > 0.
class SlopeRandomWalkFactor : public ceres::SizedCostFunction<2, 2, 2> {
 public:
  explicit SlopeRandomWalkFactor(double sigma);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  double inv_sigma_;
};

/// r = (g - g0) / sigma; block [g (2)]. Throws if sigma is not > 0.
class SlopePriorFactor : public ceres::SizedCostFunction<2, 2> {
 public:
  SlopePriorFactor(const Eigen::Vector2d& g0, double sigma);
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  Eigen::Vector2d g0_;
  double inv_sigma_;
};

}  // namespace vims
