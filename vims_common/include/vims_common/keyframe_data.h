#pragma once
/// @file keyframe_data.h
/// @brief What the VIO hands to the pose graph for every keyframe (the core-side twin of the
/// vims/Keyframe message). Defined here so the estimator and the pose graph do not depend on
/// each other.

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

namespace vims {

/// A feature the sliding window has triangulated, seen in this keyframe.
struct KeyframeLandmark {
  std::uint64_t id = 0;                                  ///< tracker id, unique over the run
  Eigen::Vector3d p_odom = Eigen::Vector3d::Zero();      ///< 3D point in the VIO (odom) frame [m]
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();       ///< observation in this image (distorted pixels)
  Eigen::Vector2d normalized = Eigen::Vector2d::Zero();  ///< undistorted normalised image coordinates
};

struct KeyframeData {
  double t = 0.0;  ///< image time (bag clock, corrected by the estimated camera-IMU offset)
  /// Increments whenever the VIO re-initialises; poses of different sessions live in
  /// unrelated odom frames, and the pose graph must not chain them with a sequential edge.
  std::uint32_t session = 0;
  Eigen::Isometry3d T_odom_b = Eigen::Isometry3d::Identity();  ///< body pose in the VIO frame
  std::vector<KeyframeLandmark> features;
  /// Depth of the pressure port below the surface at t [m] (sequences with a pressure sensor).
  std::optional<double> port_depth;
  /// The camera extrinsic (camera optical frame in body) the VIO estimates online
  /// (estimator.estimate_extrinsic); unset: the VIO uses the sequence YAML's, and so does the
  /// pose graph.
  std::optional<Eigen::Isometry3d> T_b_c;
  cv::Mat image;  ///< the keyframe image (CV_8UC1), for ORB description in the pose graph
};

}  // namespace vims
