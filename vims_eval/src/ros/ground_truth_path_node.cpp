// vims_ground_truth_path_node: shows a sequence's ground truth in rviz (replay.launch). Never
// used by the estimator.
//
// Subscribes  ground_truth/pose (geometry_msgs/PoseStamped): body in world (sensor contract)
// Publishes   ground_truth/path (nav_msgs/Path, latched) every ~publish_period_s
// Params      ~frame_id (string, default "map"): the frame the path is drawn in
//             ~anchor (string, default "first_position"): "first_position" subtracts the first
//                     pose's position, so the path starts where the pose graph's map frame starts
//                     (the first keyframe's VIO position; its yaw is absolute, from the geomagnetic
//                     field); "none" draws the world coordinates as they are
//             ~min_spacing_m (double, default 0.02): a pose closer than this to the previous
//                     path pose is left out (the path stays small over long runs)
//             ~publish_period_s (double, default 1.0)
// A stamp going backwards (a looping bag) starts the path anew; a non-finite pose is dropped.
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>

#include <cmath>
#include <optional>
#include <string>

#include "vims_ros/keyframe_conversions.h"
#include "vims_ros/odometry_conversions.h"

namespace {

class GroundTruthPathNode {
 public:
  GroundTruthPathNode(ros::NodeHandle& nh, std::string frame_id, bool anchor_first_position, double min_spacing_m,
                      double publish_period_s)
      : anchor_first_position_(anchor_first_position), min_spacing_m_(min_spacing_m) {
    path_.header.frame_id = std::move(frame_id);
    path_pub_ = nh.advertise<nav_msgs::Path>("ground_truth/path", 1, true);
    pose_sub_ = nh.subscribe("ground_truth/pose", 100, &GroundTruthPathNode::onPose, this);
    timer_ = nh.createWallTimer(ros::WallDuration(publish_period_s), &GroundTruthPathNode::onTimer, this);
    ROS_INFO_STREAM("ground truth: " << pose_sub_.getTopic() << " -> " << path_pub_.getTopic() << " in frame "
                                     << path_.header.frame_id);
  }

 private:
  void onPose(const geometry_msgs::PoseStamped::ConstPtr& msg) {
    Eigen::Isometry3d T_w_b;
    std::string why;
    if (!vims::toIsometry(msg->pose, &T_w_b, &why)) {
      ROS_WARN_STREAM_THROTTLE(5.0, "ground-truth pose dropped: " << why);
      return;
    }
    if (!path_.poses.empty() && msg->header.stamp < path_.poses.back().header.stamp) {
      ROS_WARN("ground-truth time went backwards: the path starts anew");
      path_.poses.clear();
      origin_.reset();
    }
    if (!origin_) origin_ = anchor_first_position_ ? Eigen::Vector3d(T_w_b.translation()) : Eigen::Vector3d::Zero();
    T_w_b.translation() -= *origin_;
    if (!path_.poses.empty()) {
      const auto& last = path_.poses.back().pose.position;
      const double moved = (T_w_b.translation() - Eigen::Vector3d(last.x, last.y, last.z)).norm();
      if (moved < min_spacing_m_) return;
    }
    geometry_msgs::PoseStamped pose;
    if (!vims::toPoseStampedMsg(msg->header.stamp.toSec(), T_w_b, path_.header.frame_id, &pose, &why)) {
      ROS_WARN_STREAM_THROTTLE(5.0, "ground-truth pose dropped: " << why);
      return;
    }
    path_.poses.push_back(pose);
    changed_ = true;
  }

  void onTimer(const ros::WallTimerEvent& /*event*/) {
    if (!changed_ || path_.poses.empty()) return;
    changed_ = false;
    path_.header.stamp = path_.poses.back().header.stamp;
    path_pub_.publish(path_);
  }

  const bool anchor_first_position_;
  const double min_spacing_m_;
  nav_msgs::Path path_;
  std::optional<Eigen::Vector3d> origin_;
  bool changed_ = false;
  ros::Publisher path_pub_;
  ros::Subscriber pose_sub_;
  ros::WallTimer timer_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "vims_ground_truth_path");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  const std::string frame_id = pnh.param<std::string>("frame_id", "map");
  const std::string anchor = pnh.param<std::string>("anchor", "first_position");
  const double min_spacing_m = pnh.param("min_spacing_m", 0.02);
  const double publish_period_s = pnh.param("publish_period_s", 1.0);
  if (anchor != "first_position" && anchor != "none") {
    ROS_FATAL_STREAM("parameter ~anchor must be first_position or none (is '" << anchor << "')");
    return 1;
  }
  if (!(min_spacing_m >= 0.0) || !std::isfinite(min_spacing_m)) {
    ROS_FATAL_STREAM("parameter ~min_spacing_m must be >= 0 (is " << min_spacing_m << ")");
    return 1;
  }
  if (!(publish_period_s > 0.0) || !std::isfinite(publish_period_s)) {
    ROS_FATAL_STREAM("parameter ~publish_period_s must be > 0 (is " << publish_period_s << ")");
    return 1;
  }
  GroundTruthPathNode node(nh, frame_id, anchor == "first_position", min_spacing_m, publish_period_s);
  ros::spin();
  return 0;
}
