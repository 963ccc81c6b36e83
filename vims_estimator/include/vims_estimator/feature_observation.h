#pragma once
/// @file feature_observation.h
/// @brief One feature observation as the reprojection and sonar-depth factors consume it, the
/// camera-IMU time-offset correction, and the anchor bearing of the direct-depth parameter.
///
/// Time offset td (one scalar parameter block, seconds). Convention:
///   t_stamp = t_exposure + td          (the image header stamp lags the true exposure by td)
/// A keyframe's state (pose, velocity) is placed at t_state = t_stamp - td_frame, where td_frame
/// is the td estimate the estimator used when it integrated the IMU up to that frame
/// (0 if it integrates to the stamps). The observed pixel belongs to t_exposure = t_stamp - td, so
/// at the state time the feature is, to first order in its image-plane velocity,
///   uv(t_state) = uv_obs + (t_state - t_exposure) velocity = uv_obs + (td - td_frame) velocity.
/// (VINS-Mono uses the opposite sign for td: t_imu = t_cam + td_vins, i.e. td_vins = -td.)
///
/// Direct depth (the paper's lambda_j): the feature's position in the anchor camera (its first
/// observation) is f_c = lambda * b, with b the UNIT bearing of the corrected anchor observation,
/// b = m / |m|, m = [uv_anchor(td); 1]. lambda is therefore the Euclidean distance between the
/// anchor camera centre and the feature, not the z coordinate. The reprojection and the sonar
/// depth factors both use bearing() so they agree on lambda.

#include <Eigen/Core>

namespace vims {

struct FeatureObservation {
  /// Undistorted normalised image coordinates (x/z, y/z) of the feature in the camera optical
  /// frame, as measured at the image stamp.
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();
  /// d(uv)/dt on the normalised image plane [1/s] at the state time; the VIO predicts it from its
  /// state (a difference of the tracker's positions would bias td) (0 if unknown: no td effect).
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
  /// td used to place this frame's state time (t_state = t_stamp - td_frame) [s].
  double td_frame = 0.0;
};

/// The observation moved to the frame's state time for the time offset td:
/// uv + (td - td_frame) velocity.
inline Eigen::Vector2d correctedUv(const FeatureObservation& obs, double td) {
  return obs.uv + (td - obs.td_frame) * obs.velocity;
}

/// Unit bearing b = m/|m| of m = [correctedUv(obs, td); 1]; optionally db/dtd =
/// (I - b b^T)/|m| [velocity; 0].
inline Eigen::Vector3d unitBearing(const FeatureObservation& obs, double td,
                                   Eigen::Vector3d* d_bearing_d_td = nullptr) {
  const Eigen::Vector3d m = correctedUv(obs, td).homogeneous();
  const double norm = m.norm();  // >= 1, never zero
  const Eigen::Vector3d b = m / norm;
  if (d_bearing_d_td) {
    const Eigen::Vector3d dm(obs.velocity.x(), obs.velocity.y(), 0.0);
    *d_bearing_d_td = (dm - b * b.dot(dm)) / norm;
  }
  return b;
}

}  // namespace vims
