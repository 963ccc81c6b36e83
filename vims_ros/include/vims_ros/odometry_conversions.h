#pragma once
/// @file odometry_conversions.h
/// @brief Core poses -> output messages (nav_msgs/Odometry, geometry_msgs/PoseStamped,
/// geometry_msgs/TransformStamped), shared by the estimator, pose-graph and ground-truth nodes.
/// Every conversion checks its input and returns false with a reason instead of producing a
/// message that holds NaN/inf or a stamp ros::Time cannot hold, so no node ever publishes NaN.

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <visualization_msgs/Marker.h>

#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace vims {

/// True when every entry of the pose's 3x4 matrix is finite.
bool isFinitePose(const Eigen::Isometry3d& pose);

/// A bag-clock time [s] as ros::Time. False for a non-finite or negative time or one past
/// ros::Time's range.
bool toRosTime(double t, ros::Time* out, std::string* why);

/// Odometry of the body (child frame) in the parent frame (REP 105): pose = T_parent_b,
/// twist in the child frame (nav_msgs/Odometry's convention): linear = R_parent_b^T v_parent_b,
/// angular = omega_b. Covariances are left zero (unknown). False for non-finite input.
bool toOdometryMsg(double t, const Eigen::Isometry3d& T_parent_b, const Eigen::Vector3d& v_parent_b,
                   const Eigen::Vector3d& omega_b, const std::string& parent_frame, const std::string& child_frame,
                   nav_msgs::Odometry* out, std::string* why);

/// T_parent_child as a tf message. False for a non-finite pose or an unusable time.
bool toTransformMsg(double t, const Eigen::Isometry3d& T_parent_child, const std::string& parent_frame,
                    const std::string& child_frame, geometry_msgs::TransformStamped* out, std::string* why);

/// A stamped pose (for nav_msgs/Path). False for a non-finite pose or an unusable time.
bool toPoseStampedMsg(double t, const Eigen::Isometry3d& pose, const std::string& frame,
                      geometry_msgs::PoseStamped* out, std::string* why);

/// The estimated local seabed under the body for rviz: a thin square plate of side `size_m`
/// centred below the body at height `seabed_z`, tilted to the plane of gradient `slope`
/// (dh/dx, dh/dy) in the parent frame. False for non-finite input or an unusable time.
bool toSeabedMarkerMsg(double t, const Eigen::Vector2d& body_xy, double seabed_z, const Eigen::Vector2d& slope,
                       double size_m, const std::string& frame, visualization_msgs::Marker* out, std::string* why);

/// Points (e.g. the recent sonar hits on the seabed) as a POINTS marker of `size_m` squares.
/// False (nothing to draw) when no point is finite or the time is unusable; non-finite points are
/// skipped.
bool toPointsMarkerMsg(double t, const std::vector<Eigen::Vector3d>& points, double size_m, const std::string& frame,
                       const std::string& ns, visualization_msgs::Marker* out, std::string* why);

}  // namespace vims
