/// Relocalisation: verification against a candidate the query's run is not joined to yet
/// (LoopDetectorOptions::guided_min_inliers). A place flown the other way and to the side shares
/// part of its view; the guided search turns a weak or tilted PnP consensus into a loop with the
/// right pose, and never into a loop at another place. And tracking a joined map from the pose
/// graph's prediction (track_map_candidates).

#include <gtest/gtest.h>

#include <tuple>

#include "loop_test_world.h"
#include "loop_verification_helpers.h"
#include "vims_pose_graph/keyframe_description.h"
#include "vims_pose_graph/loop_detector.h"
#include "vims_pose_graph/multiscale_map.h"

namespace vims {
namespace {

using namespace test;  // loop_test_world.h and loop_verification_helpers.h

/// A map of one pass along +x at 2.5 m (tracker-selected corners, the manager's describer
/// settings) and queries described as the manager describes them (tracked points of the query
/// and its three predecessors, seabed corners), in a session of their own: another component
/// until `join` links it to the map.
struct RelocalisationScene {
  explicit RelocalisationScene(const LoopDetectorOptions& o)
      : world(kWorldSeed),
        map(test::vocabulary("orb_k8l4.vocab"), PoseGraphOptions(), 0.0),
        describer(FeatureExtractionOptions(), o.harris_threshold, world.camera()) {
    describer.setDenseCorners(o.submap_dense_corners, o.submap_corner_min_distance_px, o.submap_corner_max_level);
    describer.setDenseCornersPerLevel(o.submap_dense_corners_per_level);
    describer.setSeabedCorners(o.query_seabed_corners, o.submap_corner_min_distance_px, o.submap_corner_max_level);
    map_poses = addTrackerPass(world, describer, 2.5, 100, &map);
    query_session = map.addSession(1, false);
  }

  /// A pass of four keyframes 0.3 m apart at `heading_deg` ending with its camera over
  /// `camera_xy`, in an unrelated VIO frame; returns the last keyframe's query. The keyframes'
  /// world positions in the map are the truth plus `world_error` (the graph's estimate).
  LoopQuery queryAt(const Eigen::Vector2d& camera_xy, double heading_deg, double t0,
                    const Eigen::Vector3d& world_error = Eigen::Vector3d::Zero()) {
    const Eigen::Isometry3d T_odom_w = yawTransform(-70.0, Eigen::Vector3d(12.0, -4.0, 0.3));
    LoopQuery q;
    for (int j = 3; j >= 0; --j) {
      const Eigen::Vector2d back = Eigen::Rotation2Dd(heading_deg * kDeg) * Eigen::Vector2d(-0.3 * j, 0.0);
      const Eigen::Isometry3d T_w_b = poseWithCameraAt(camera_xy + back, 2.6, heading_deg, -1.0, 1.5);
      const KeyframeData kf = world.trackerKeyframe(t0 - j, 1, T_w_b, T_odom_w * T_w_b, 300 + static_cast<uint32_t>(j));
      const KeyframeDescription d = describer.describeKeyframeAndSeabed(
          kf.image, kf.features, kf.T_odom_b * world.camera().T_b_c, map.vocabulary().get());
      const PoseGraphNodeId n = map.addNode(kf.t, query_session, kf.T_odom_b, T_w_b.translation() + world_error,
                                            yawPitchRollFromRotation(T_w_b.linear()).yaw, d.submap, true);
      mergeDescribedPoints(&q.points, d.points);
      if (j > 0) continue;
      q.node = n;
      q.t = kf.t;
      q.T_odom_b = kf.T_odom_b;
      q.bow = d.submap.bow;
      q.seabed_points = d.seabed_points;
      T_w_query = T_w_b;
    }
    return q;
  }

  test::TestWorld world;
  MultiScaleMap map;
  KeyframeDescriber describer;
  std::vector<Eigen::Isometry3d> map_poses;
  uint32_t query_session = 0;
  Eigen::Isometry3d T_w_query = Eigen::Isometry3d::Identity();
};

// The repeat flies the map's pass the other way, 1.1 m to the side (the camera footprint is
// 2.9 m across at 2.6 m): the plain checks find too few matches, or a consensus whose pose is
// tilted; relocalisation's guided search accepts the place with the right pose. Within one
// component (the run already joined to the map) the plain checks apply.
TEST(Relocalisation, AReversedPassBesideTheMapIsFoundByGuidedMatching) {
  const LoopDetectorOptions defaults = testLoopOptions();
  ASSERT_GT(defaults.guided_min_inliers, 0);
  RelocalisationScene scene(defaults);
  const LoopQuery q = scene.queryAt(Eigen::Vector2d(1.2, 1.1), 180.0, 100.0);
  const PoseGraphNodeId match = 3;
  const Eigen::Isometry3d T_match_query_gt = scene.map_poses[match].inverse() * scene.T_w_query;

  LoopDetectorOptions plain = defaults;
  plain.guided_min_inliers = 0;
  const VerificationResult without = LoopVerifier(plain, scene.world.camera()).verify(q, scene.map, match);
  EXPECT_NE(without.stage, LoopStage::kAccepted)
      << "the plain checks accept it (" << without.num_inliers << " inliers): the test no longer needs guidance";

  const VerificationResult guided = LoopVerifier(defaults, scene.world.camera()).verify(q, scene.map, match);
  ASSERT_EQ(guided.stage, LoopStage::kAccepted)
      << "matches " << guided.num_matches << ", inliers " << guided.num_inliers << ", stage " << toString(guided.stage);
  EXPECT_GE(guided.num_inliers, defaults.pnp_min_inliers);
  EXPECT_LT(guided.tilt_error_deg, 0.5);
  // The loop edge's sigmas (0.1 m, 1 deg yaw) plus the roll and pitch the graph drops.
  expectPoseNear(guided.T_match_query, T_match_query_gt, 0.1, 2.0);

  // Joined: the same query within the map's component gets the plain checks.
  const auto last_map_node = static_cast<PoseGraphNodeId>(scene.map_poses.size() - 1);
  scene.map.addSessionLink(last_map_node, last_map_node + 1, 1.0, 0.3);
  ASSERT_TRUE(scene.map.sameComponent(match, q.node));
  const VerificationResult joined = LoopVerifier(defaults, scene.world.camera()).verify(q, scene.map, match);
  EXPECT_EQ(joined.stage, without.stage);
  EXPECT_EQ(joined.num_inliers, without.num_inliers);
}

// The guided search never makes a loop at another place: queries over another part of the same
// kind of seabed, at the map's heading and reversed, against every map keyframe, with half the
// default consensus as a hypothesis (wrong places then reach the guided search: 6-11 inliers).
TEST(Relocalisation, GuidedMatchingAcceptsNoOtherPlace) {
  LoopDetectorOptions o = testLoopOptions();
  o.guided_min_inliers = o.guided_min_inliers / 2;
  RelocalisationScene scene(o);
  int guided = 0;
  for (const double heading : {0.0, 180.0}) {
    const LoopQuery q = scene.queryAt(Eigen::Vector2d(30.0 + heading / 30.0, -9.0), heading, 100.0 + heading);
    for (PoseGraphNodeId candidate = 0; candidate < 7; ++candidate) {
      const VerificationResult r = LoopVerifier(o, scene.world.camera()).verify(q, scene.map, candidate);
      EXPECT_NE(r.stage, LoopStage::kAccepted) << "heading " << heading << ", candidate " << candidate;
      if (r.stage == LoopStage::kPnp && r.num_inliers >= o.guided_min_inliers) ++guided;
    }
  }
  EXPECT_GE(guided, 7) << "too few wrong places reach the guided search for the test to show it";
}

// Tracking a joined map (LoopDetectorOptions::track_map_candidates): the same reversed pass
// beside the map, which the plain checks reject within the component, is found from the pose
// graph's prediction of where the map keyframe sees the query's points; a prediction 1 m off
// finds nothing, and across components there is no prediction.
TEST(MapTracking, APredictedPoseFindsTheMapWhereAppearanceDoesNot) {
  const LoopDetectorOptions o = testLoopOptions();
  ASSERT_GT(o.track_map_candidates, 0);
  const PoseGraphNodeId match = 3;
  const auto verifyJoined = [&](const Eigen::Vector3d& world_error, bool join) {
    RelocalisationScene scene(o);
    const LoopQuery q = scene.queryAt(Eigen::Vector2d(1.2, 1.1), 180.0, 100.0, world_error);
    const auto last_map_node = static_cast<PoseGraphNodeId>(scene.map_poses.size() - 1);
    if (join) scene.map.addSessionLink(last_map_node, last_map_node + 1, 1.0, 0.3);
    const LoopVerifier verifier(o, scene.world.camera());
    const VerificationResult plain = verifier.verify(q, scene.map, match);
    const VerificationResult predicted = verifier.verifyFromPrediction(q, scene.map, match);
    return std::make_tuple(plain, predicted, scene.map_poses[match].inverse() * scene.T_w_query);
  };
  const auto [plain, predicted, T_match_query_gt] = verifyJoined(Eigen::Vector3d::Zero(), true);
  EXPECT_NE(plain.stage, LoopStage::kAccepted);
  ASSERT_EQ(predicted.stage, LoopStage::kAccepted)
      << "matches " << predicted.num_matches << ", inliers " << predicted.num_inliers;
  EXPECT_GE(predicted.num_inliers, o.pnp_min_inliers);
  expectPoseNear(predicted.T_match_query, T_match_query_gt, 0.1, 2.0);

  const auto [plain_off, predicted_off, unused] = verifyJoined(Eigen::Vector3d(1.0, 0.0, 0.0), true);
  EXPECT_NE(predicted_off.stage, LoopStage::kAccepted) << predicted_off.num_inliers << " inliers";
  const auto [plain_apart, predicted_apart, unused_apart] = verifyJoined(Eigen::Vector3d::Zero(), false);
  EXPECT_EQ(predicted_apart.stage, LoopStage::kMatching);
  EXPECT_EQ(predicted_apart.num_matches, 0);
}

}  // namespace
}  // namespace vims
