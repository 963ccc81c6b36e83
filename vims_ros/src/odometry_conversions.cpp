#include "vims_ros/odometry_conversions.h"

#include <cmath>
#include <limits>

#include "vims_ros/keyframe_conversions.h"

namespace vims {
namespace {
bool fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}
}  // namespace

bool isFinitePose(const Eigen::Isometry3d& pose) { return pose.matrix().topRows<3>().allFinite(); }

bool toRosTime(double t, ros::Time* out, std::string* why) {
  // ros::Time holds unsigned 32-bit seconds.
  if (!std::isfinite(t) || t < 0.0 || t >= static_cast<double>(std::numeric_limits<uint32_t>::max())) {
    return fail(why, "time " + std::to_string(t) + " s cannot be a ros::Time");
  }
  *out = ros::Time(t);
  return true;
}

bool toOdometryMsg(double t, const Eigen::Isometry3d& T_parent_b, const Eigen::Vector3d& v_parent_b,
                   const Eigen::Vector3d& omega_b, const std::string& parent_frame, const std::string& child_frame,
                   nav_msgs::Odometry* out, std::string* why) {
  if (!isFinitePose(T_parent_b)) return fail(why, "non-finite pose");
  if (!v_parent_b.allFinite()) return fail(why, "non-finite velocity");
  if (!omega_b.allFinite()) return fail(why, "non-finite angular rate");
  ros::Time stamp;
  if (!toRosTime(t, &stamp, why)) return false;
  nav_msgs::Odometry msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = parent_frame;
  msg.child_frame_id = child_frame;
  msg.pose.pose = toPoseMsg(T_parent_b);
  const Eigen::Vector3d v_b = T_parent_b.rotation().transpose() * v_parent_b;
  msg.twist.twist.linear.x = v_b.x();
  msg.twist.twist.linear.y = v_b.y();
  msg.twist.twist.linear.z = v_b.z();
  msg.twist.twist.angular.x = omega_b.x();
  msg.twist.twist.angular.y = omega_b.y();
  msg.twist.twist.angular.z = omega_b.z();
  *out = std::move(msg);
  return true;
}

bool toTransformMsg(double t, const Eigen::Isometry3d& T_parent_child, const std::string& parent_frame,
                    const std::string& child_frame, geometry_msgs::TransformStamped* out, std::string* why) {
  if (!isFinitePose(T_parent_child)) return fail(why, "non-finite transform");
  ros::Time stamp;
  if (!toRosTime(t, &stamp, why)) return false;
  const geometry_msgs::Pose pose = toPoseMsg(T_parent_child);
  out->header.stamp = stamp;
  out->header.frame_id = parent_frame;
  out->child_frame_id = child_frame;
  out->transform.translation.x = pose.position.x;
  out->transform.translation.y = pose.position.y;
  out->transform.translation.z = pose.position.z;
  out->transform.rotation = pose.orientation;
  return true;
}

bool toPoseStampedMsg(double t, const Eigen::Isometry3d& pose, const std::string& frame,
                      geometry_msgs::PoseStamped* out, std::string* why) {
  if (!isFinitePose(pose)) return fail(why, "non-finite pose");
  ros::Time stamp;
  if (!toRosTime(t, &stamp, why)) return false;
  out->header.stamp = stamp;
  out->header.frame_id = frame;
  out->pose = toPoseMsg(pose);
  return true;
}

bool toSeabedMarkerMsg(double t, const Eigen::Vector2d& body_xy, double seabed_z, const Eigen::Vector2d& slope,
                       double size_m, const std::string& frame, visualization_msgs::Marker* out, std::string* why) {
  if (!body_xy.allFinite() || !std::isfinite(seabed_z) || !slope.allFinite() || !(size_m > 0.0)) {
    if (why) *why = "non-finite seabed";
    return false;
  }
  if (!toRosTime(t, &out->header.stamp, why)) return false;
  out->header.frame_id = frame;
  out->ns = "seabed";
  out->id = 0;
  out->type = visualization_msgs::Marker::CUBE;
  out->action = visualization_msgs::Marker::ADD;
  out->pose.position.x = body_xy.x();
  out->pose.position.y = body_xy.y();
  out->pose.position.z = seabed_z;
  // The plate's z axis along the plane's normal (-g_x, -g_y, 1).
  const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(
      Eigen::Vector3d::UnitZ(), Eigen::Vector3d(-slope.x(), -slope.y(), 1.0).normalized());
  out->pose.orientation.x = q.x();
  out->pose.orientation.y = q.y();
  out->pose.orientation.z = q.z();
  out->pose.orientation.w = q.w();
  out->scale.x = size_m;
  out->scale.y = size_m;
  out->scale.z = 0.01;
  out->color.r = 0.85f;
  out->color.g = 0.65f;
  out->color.b = 0.3f;
  out->color.a = 0.5f;
  return true;
}

bool toPointsMarkerMsg(double t, const std::vector<Eigen::Vector3d>& points, double size_m, const std::string& frame,
                       const std::string& ns, visualization_msgs::Marker* out, std::string* why) {
  if (!toRosTime(t, &out->header.stamp, why)) return false;
  out->header.frame_id = frame;
  out->ns = ns;
  out->id = 0;
  out->type = visualization_msgs::Marker::POINTS;
  out->action = visualization_msgs::Marker::ADD;
  out->pose.orientation.w = 1.0;
  out->scale.x = size_m;
  out->scale.y = size_m;
  out->color.r = 1.0f;
  out->color.g = 0.3f;
  out->color.b = 0.1f;
  out->color.a = 1.0f;
  out->points.clear();
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) continue;
    geometry_msgs::Point q;
    q.x = p.x();
    q.y = p.y();
    q.z = p.z();
    out->points.push_back(q);
  }
  if (out->points.empty()) {
    if (why) *why = "no finite point";
    return false;
  }
  return true;
}

}  // namespace vims
