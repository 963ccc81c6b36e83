#pragma once
/// @file window_hit_factor.h
/// @brief The sonar depth factor across keyframes: a feature first seen in keyframe a lies on the
/// seabed plane through the sonar hit of another window keyframe j (docs/factors.md 5g).
///
/// The downward camera sees seabed the vehicle is about to fly over, so on a seabed with relief
/// the hit nearest to a feature is often a later keyframe's, centimetres from it, where its
/// anchor's own hit is a metre or more away (SonarDepthOptions::tie_to_nearest_hit). Both poses
/// are states of the window, so the tie moves with them, unlike a hit that left the window.
///
/// States: pose_a = T_l_ba (the anchor), pose_j = T_l_bj (the keyframe whose beam hit the seabed),
/// extrinsic T_b_c, the feature's direct depth lambda, td, and (seabed model `local_plane`) the
/// seabed gradient g_j = (dh/dx, dh/dy) under keyframe j. Constants: the anchor observation, the
/// filtered range d[j] at keyframe j's state time and the sonar extrinsic T_b_s.
///
///   seabed point  s_l = p_j + R_j s_b,  s_b = p_bs + d[j] R_bs e_z
///   feature       f_l = p_a + R_a f_b,  f_b = p_bc + lambda R_bc b
///   r = (s_l)_z + g_j . ((f_l)_xy - (s_l)_xy) - (f_l)_z = n^T (s_l - f_l),  n = (-g_x, -g_y, 1)
///
/// It is the seabed height factor (sonar_depth_factor.h) on the plane through s_l, so the anchor's,
/// the extrinsic's, lambda's and td's Jacobians are that factor's; the hit adds
///   dr/dp_j = n^T     dr/dth_j = -n^T R_j [s_b]x     dr/dg_j = ((f_l - s_l)_x, (f_l - s_l)_y)
/// Unlike the anchor's own sonar factor the positions no longer cancel: r depends on the height
/// and horizontal offset between the two keyframes, which the IMU and the other factors hold.
/// With a = j it is exactly the (sloped) sonar depth factor. sigma as the sonar depth factor's
/// (SonarDepthOptions::sigmaAt) at the feature's distance from s_l; the factor returns r / sigma.

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "vims_estimator/factors/sonar_depth_factor.h"
#include "vims_estimator/feature_observation.h"

namespace vims {

/// The hit point s_l of keyframe j's beam in frame l as the plane of the seabed height residual:
/// height (s_l)_z, position (s_l)_xy, gradient `slope` (zero: the horizontal seabed).
SeabedPlane windowHitPlane(double range, const Eigen::Isometry3d& T_b_s, const Eigen::Isometry3d& T_l_bj,
                           const Eigen::Vector2d& slope = Eigen::Vector2d::Zero());

/// Horizontal seabed (model `horizontal`): parameter blocks [pose_a (7), pose_j (7), T_b_c (7),
/// lambda (1), td (1)]; returns r / sigma with g_j = 0. The range is keyframe j's; same argument
/// checks as SonarDepthFactor.
class WindowHitFactor : public ceres::SizedCostFunction<1, 7, 7, 7, 1, 1> {
 public:
  WindowHitFactor(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s, double sigma);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  SonarHitMeasurement hit_;
};

/// Local seabed plane (model `local_plane`): parameter blocks [pose_a (7), pose_j (7), T_b_c (7),
/// lambda (1), td (1), slope_j (2)]; returns r / sigma.
class SlopedWindowHitFactor : public ceres::SizedCostFunction<1, 7, 7, 7, 1, 1, 2> {
 public:
  SlopedWindowHitFactor(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s, double sigma);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  SonarHitMeasurement hit_;
};

}  // namespace vims
