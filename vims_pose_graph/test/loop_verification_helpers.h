#pragma once
/// @file loop_verification_helpers.h
/// @brief What the loop verification tests share (test_loop_verification*.cpp): their options,
/// a first visit flown as the real tracker picks corners, and a pose comparison.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <vector>

#include "loop_test_world.h"
#include "vims_pose_graph/keyframe_description.h"
#include "vims_pose_graph/loop_detector.h"
#include "vims_pose_graph/multiscale_map.h"

namespace vims {
namespace test {

constexpr uint64_t kWorldSeed = 4242;  // not the vocabulary's training world (9001)

inline LoopDetectorOptions testLoopOptions() {
  LoopDetectorOptions o;
  // The test maps are short: a few keyframes, seconds apart.
  o.exclude_recent_keyframes = 3;
  o.exclude_recent_s = 1.0;
  return o;
}

/// The first visit of the revisit tests: a pass along +x at `altitude`, 7 keyframes 0.4 m apart
/// as the real tracker picks corners (image seeds image_seed + i), in a new session whose VIO
/// frame is the world. Returns the body poses.
inline std::vector<Eigen::Isometry3d> addTrackerPass(const test::TestWorld& world, KeyframeDescriber& describer,
                                                     double altitude, uint32_t image_seed, MultiScaleMap* map) {
  std::vector<Eigen::Isometry3d> poses;
  const uint32_t session = map->addSession(0, false);
  for (int i = 0; i < 7; ++i) {
    const Eigen::Isometry3d T_w_b = bodyPose(0.4 * i, 0.0, altitude, 0.0, 1.0, -0.5);
    poses.push_back(T_w_b);
    const KeyframeData kf = world.trackerKeyframe(1.0 * i, 0, T_w_b, T_w_b, image_seed + static_cast<uint32_t>(i));
    DescribedPoints unused;
    map->addNode(kf.t, session, T_w_b, T_w_b.translation(), 0.0,
                 describer.describeKeyframe(kf.image, kf.features, map->vocabulary().get(), &unused), true);
    if (i > 0) map->addSequentialEdge(static_cast<PoseGraphNodeId>(i - 1), static_cast<PoseGraphNodeId>(i));
  }
  return poses;
}

inline void expectPoseNear(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth, double max_m,
                           double max_deg) {
  const double dp = (estimate.translation() - truth.translation()).norm();
  const double da = Eigen::AngleAxisd(estimate.linear().transpose() * truth.linear()).angle() / kDeg;
  EXPECT_LT(dp, max_m) << "estimate " << estimate.translation().transpose() << " truth "
                       << truth.translation().transpose();
  EXPECT_LT(da, max_deg);
}

/// A body pose whose camera (0.25 m ahead of the body) is over `camera_xy`, turned by `heading_deg`.
inline Eigen::Isometry3d poseWithCameraAt(const Eigen::Vector2d& camera_xy, double z, double heading_deg,
                                          double pitch_deg = 0.0, double roll_deg = 0.0) {
  const Eigen::Vector2d body_xy = camera_xy - Eigen::Rotation2Dd(heading_deg * kDeg) * Eigen::Vector2d(0.25, 0.0);
  return bodyPose(body_xy.x(), body_xy.y(), z, heading_deg, pitch_deg, roll_deg);
}

}  // namespace test
}  // namespace vims
