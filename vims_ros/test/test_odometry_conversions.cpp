#include <gtest/gtest.h>

#include <limits>
#include <thread>
#include <vector>

#include "vims_ros/bounded_queue.h"
#include "vims_ros/keyframe_conversions.h"
#include "vims_ros/odometry_conversions.h"

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Eigen::Isometry3d makePose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();  // yaw 90 deg
  T.translation() = Eigen::Vector3d(1.0, -2.0, 3.5);
  return T;
}

}  // namespace

TEST(OdometryConversions, TwistIsInTheChildFrame) {
  nav_msgs::Odometry msg;
  std::string why;
  // Moving north (+y of odom) while facing north (yaw 90 deg): forward (+x) in the body.
  ASSERT_TRUE(vims::toOdometryMsg(12.5, makePose(), Eigen::Vector3d(0.0, 0.4, 0.1), Eigen::Vector3d(0.01, 0.02, 0.03),
                                  "odom", "base_link", &msg, &why))
      << why;
  EXPECT_EQ(msg.header.frame_id, "odom");
  EXPECT_EQ(msg.child_frame_id, "base_link");
  EXPECT_DOUBLE_EQ(msg.header.stamp.toSec(), 12.5);
  EXPECT_NEAR(msg.twist.twist.linear.x, 0.4, 1e-12);
  EXPECT_NEAR(msg.twist.twist.linear.y, 0.0, 1e-12);
  EXPECT_NEAR(msg.twist.twist.linear.z, 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(msg.twist.twist.angular.z, 0.03);
  Eigen::Isometry3d back;
  ASSERT_TRUE(vims::toIsometry(msg.pose.pose, &back, &why)) << why;
  EXPECT_TRUE(back.isApprox(makePose(), 1e-12));
}

TEST(OdometryConversions, RejectsNonFiniteInputAndBadTimes) {
  nav_msgs::Odometry msg;
  std::string why;
  Eigen::Isometry3d bad = makePose();
  bad.translation().x() = kNaN;
  EXPECT_FALSE(vims::toOdometryMsg(1.0, bad, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), "o", "b", &msg, &why));
  EXPECT_NE(why.find("pose"), std::string::npos);
  EXPECT_FALSE(
      vims::toOdometryMsg(1.0, makePose(), Eigen::Vector3d(kNaN, 0, 0), Eigen::Vector3d::Zero(), "o", "b", &msg, &why));
  EXPECT_NE(why.find("velocity"), std::string::npos);
  EXPECT_FALSE(
      vims::toOdometryMsg(1.0, makePose(), Eigen::Vector3d::Zero(), Eigen::Vector3d(0, kNaN, 0), "o", "b", &msg, &why));
  EXPECT_FALSE(
      vims::toOdometryMsg(-1.0, makePose(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), "o", "b", &msg, &why));
  EXPECT_FALSE(
      vims::toOdometryMsg(kNaN, makePose(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), "o", "b", &msg, &why));

  geometry_msgs::TransformStamped tf;
  EXPECT_FALSE(vims::toTransformMsg(1.0, bad, "odom", "base_link", &tf, &why));
  ASSERT_TRUE(vims::toTransformMsg(2.0, makePose(), "odom", "base_link", &tf, &why)) << why;
  EXPECT_EQ(tf.header.frame_id, "odom");
  EXPECT_EQ(tf.child_frame_id, "base_link");
  EXPECT_DOUBLE_EQ(tf.transform.translation.y, -2.0);
  EXPECT_NEAR(tf.transform.rotation.z, std::sqrt(0.5), 1e-12);

  geometry_msgs::PoseStamped pose;
  EXPECT_FALSE(vims::toPoseStampedMsg(1.0, bad, "map", &pose, &why));
  ASSERT_TRUE(vims::toPoseStampedMsg(3.0, makePose(), "map", &pose, &why)) << why;
  EXPECT_EQ(pose.header.frame_id, "map");
  EXPECT_DOUBLE_EQ(pose.pose.position.z, 3.5);
}

TEST(BoundedQueue, RefusesWhenFullAndKeepsOrder) {
  vims::BoundedQueue<int> queue(3);
  EXPECT_TRUE(queue.push(1));
  EXPECT_TRUE(queue.push(2));
  EXPECT_TRUE(queue.push(3));
  EXPECT_FALSE(queue.push(4));  // full: the incoming item is dropped
  EXPECT_EQ(queue.dropped(), 1u);
  EXPECT_EQ(*queue.pop(), 1);
  EXPECT_TRUE(queue.push(5));
  EXPECT_EQ(*queue.pop(), 2);
  EXPECT_EQ(*queue.pop(), 3);
  EXPECT_EQ(*queue.pop(), 5);
  EXPECT_EQ(queue.size(), 0u);
}

TEST(BoundedQueue, DrainsAfterCloseAndWakesTheConsumer) {
  vims::BoundedQueue<int> queue(10);
  queue.push(7);
  queue.push(8);
  queue.close();
  EXPECT_FALSE(queue.push(9));  // closed
  EXPECT_EQ(*queue.pop(), 7);
  EXPECT_EQ(*queue.pop(), 8);
  EXPECT_FALSE(queue.pop().has_value());

  // A consumer blocked in pop() returns once the queue is closed.
  vims::BoundedQueue<int> empty(2);
  std::vector<int> seen;
  std::thread consumer([&] {
    while (auto item = empty.pop()) seen.push_back(*item);
  });
  for (int i = 0; i < 100; ++i) {
    while (!empty.push(i)) std::this_thread::yield();
  }
  empty.close();
  consumer.join();
  ASSERT_EQ(seen.size(), 100u);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(seen[i], i);
}
