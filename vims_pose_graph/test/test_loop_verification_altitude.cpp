/// Loop verification across altitude: revisits flown higher or lower than the first visit
/// (scale-aware matching), the query's own seabed corners, and candidates from the pose graph's
/// estimate; on keyframes rendered by the simulator's seabed renderer.

#include <gtest/gtest.h>

#include <cmath>

#include "loop_verification_helpers.h"

namespace vims {
namespace {

using namespace test;  // loop_test_world.h and loop_verification_helpers.h

// ---------------------------------------------------------------------------------------------
// Revisits at another altitude (scale-aware matching, pose-graph candidates)
// ---------------------------------------------------------------------------------------------

TEST(PointMatching, AltitudeLevelShiftAndLevelWindow) {
  // 3.6 m / 2.5 m = 1.44 = 1.2^2: a query flown higher sees the seabed two levels smaller.
  EXPECT_NEAR(altitudeLevelShift(3.6, 2.5, 1.2), 2.0, 1e-12);
  EXPECT_NEAR(altitudeLevelShift(2.5, 3.6, 1.2), -2.0, 1e-12);
  EXPECT_NEAR(altitudeLevelShift(3.0, 3.0, 1.2), 0.0, 1e-12);
  EXPECT_TRUE(std::isnan(altitudeLevelShift(0.0, 2.5, 1.2)));
  EXPECT_TRUE(std::isnan(altitudeLevelShift(2.5, -1.0, 1.2)));
  EXPECT_TRUE(std::isnan(altitudeLevelShift(2.5, 3.0, 1.0)));
  const LevelWindow predicted{2.0, 1.0};
  EXPECT_TRUE(predicted.admits(0, 1));
  EXPECT_TRUE(predicted.admits(0, 2));
  EXPECT_TRUE(predicted.admits(0, 3));
  EXPECT_FALSE(predicted.admits(0, 0));
  EXPECT_FALSE(predicted.admits(0, 4));
  EXPECT_FALSE(predicted.admits(2, 2));
  EXPECT_TRUE(LevelWindow::around(-1).admits(0, 7));
  EXPECT_TRUE(LevelWindow::around(2).admits(3, 1));
  EXPECT_FALSE(LevelWindow::around(2).admits(3, 0));
  // Median depth of points 2, 3 and 4 m below a camera at the origin looking along +z.
  DescribedPoints p;
  for (double z : {4.0, 2.0, 3.0, -1.0}) p.p_odom.emplace_back(0.1, -0.2, z);
  EXPECT_NEAR(medianQueryDepth(p, Eigen::Isometry3d::Identity()), 3.0, 1e-12);
}

namespace {
/// A first visit along +x at `map_altitude` (keyframes as the real tracker picks corners, dense
/// corners in the submaps) and a query over keyframe 3's place flown at `query_altitude`, turned
/// by 100 deg, in another VIO frame, joined to the first visit's component by a session link
/// (one run: their world heights compare). The query is built as PoseGraphManager builds it:
/// its points, the local map of 3 preceding keyframes, and its own seabed corners (if enabled).
struct AltitudeRevisit {
  AltitudeRevisit(const test::TestWorld& world, const LoopDetectorOptions& o, double map_altitude,
                  double query_altitude)
      : map(test::vocabulary("orb_k8l4.vocab"), PoseGraphOptions(), 0.0),
        describer(FeatureExtractionOptions(), o.harris_threshold, world.camera()) {
    describer.setDenseCorners(o.submap_dense_corners, o.submap_corner_min_distance_px, o.submap_corner_max_level);
    describer.setDenseCornersPerLevel(o.submap_dense_corners_per_level);
    poses = addTrackerPass(world, describer, map_altitude, 300, &map);
    const Eigen::Isometry3d T_odom_w = yawTransform(-70.0, Eigen::Vector3d(12.0, -4.0, 0.3));
    const uint32_t s1 = map.addSession(1, false);
    std::vector<DescribedPoints> previous;
    DescribedPoints seabed;
    for (int j = 3; j >= 0; --j) {
      const Eigen::Vector2d along = Eigen::Rotation2Dd(100.0 * kDeg) * Eigen::Vector2d(-0.25 * j, 0.0);
      const Eigen::Isometry3d T_w_b =
          poseWithCameraAt(Eigen::Vector2d(1.5, 0.1) + along, query_altitude, 100.0, -1.0, 1.5);
      const KeyframeData kf =
          world.trackerKeyframe(100.0 - j, 1, T_w_b, T_odom_w * T_w_b, 400 + static_cast<uint32_t>(j));
      DescribedPoints points;
      const VisualSubmap v = describer.describeKeyframe(kf.image, kf.features, map.vocabulary().get(), &points);
      const PoseGraphNodeId n = map.addNode(kf.t, s1, kf.T_odom_b, T_w_b.translation(),
                                            yawPitchRollFromRotation(T_w_b.linear()).yaw, v, true);
      if (j == 3)
        map.addSessionLink(6, n, 1.0, 0.5);
      else
        map.addSequentialEdge(n - 1, n);
      if (j > 0) {
        previous.push_back(std::move(points));
        continue;
      }
      if (o.query_seabed_corners > 0)
        seabed = describer.describeSeabedCorners(kf.image, points, kf.T_odom_b * world.camera().T_b_c,
                                                 o.query_seabed_corners, o.submap_corner_min_distance_px,
                                                 o.submap_corner_max_level);
      query.node = n;
      query.t = kf.t;
      query.T_odom_b = kf.T_odom_b;
      query.bow = v.bow;
      query.points = std::move(points);
      T_w_bq = T_w_b;
    }
    for (auto it = previous.rbegin(); it != previous.rend(); ++it) mergeDescribedPoints(&query.points, *it);
    query.seabed_points = std::move(seabed);
  }

  MultiScaleMap map;
  KeyframeDescriber describer;
  std::vector<Eigen::Isometry3d> poses;
  LoopQuery query;
  Eigen::Isometry3d T_w_bq = Eigen::Isometry3d::Identity();
};

/// The options before scale-aware matching: +-2 levels around each descriptor's level, dense
/// corners replicated from level 0, no seabed corners of the query, no pose-graph candidates.
LoopDetectorOptions withoutScaleAwareMatching(LoopDetectorOptions o) {
  o.match_level_from_altitude = false;
  o.submap_dense_corners_per_level = false;
  o.query_seabed_corners = 0;
  o.proximity_candidates = 0;
  return o;
}
}  // namespace

// Places flown again 1.3 m higher (2.5 -> 3.8 m: the seabed 1.52x = 2.3 ORB levels smaller in
// the image) and 1.6 m lower (4.1 -> 2.5 m: 1.64x = 2.7 levels larger). Before: the query's
// level-0 tracked corners and the candidate's level-0 corners are different point sets at that
// scale change, and the +-2 level window compares the wrong levels; both revisits were rejected.
// The defaults (levels predicted from the two altitudes, dense corners detected per level, the
// query's own seabed corners on the coarser levels) accept both with the right relative pose.
// (2.5 -> 4.1 m is matched too, 64 inliers, but its PnP pose is tilted by 2.2 deg over the flat
// seabed and pnp_max_tilt_error_deg rejects it.)
TEST(LoopVerification, RevisitFromAnotherAltitudeNeedsScaleAwareMatching) {
  test::TestWorld world(kWorldSeed);
  const PoseGraphNodeId match = 3;
  for (const auto& [map_altitude, query_altitude] : {std::pair<double, double>{2.5, 3.8}, {4.1, 2.5}}) {
    SCOPED_TRACE(VIMS_STR("first visit at " << map_altitude << " m, query at " << query_altitude << " m"));
    const LoopDetectorOptions before = withoutScaleAwareMatching(testLoopOptions());
    const AltitudeRevisit old_revisit(world, before, map_altitude, query_altitude);
    const VerificationResult r_old =
        LoopVerifier(before, world.camera()).verify(old_revisit.query, old_revisit.map, match);

    const LoopDetectorOptions o = testLoopOptions();
    ASSERT_TRUE(o.match_level_from_altitude);
    const AltitudeRevisit revisit(world, o, map_altitude, query_altitude);
    const LoopVerifier verifier(o, world.camera());
    const LevelWindow w = verifier.levelWindow(revisit.query, revisit.map, match);
    // log(d_q / d_c) / log(1.2) = +-2.7 levels (flat seabed: depth = camera height up to the tilts).
    EXPECT_NEAR(w.shift, std::log(query_altitude / map_altitude) / std::log(1.2), 0.15);
    EXPECT_DOUBLE_EQ(w.tolerance, o.match_predicted_level_tolerance);
    const VerificationResult r = verifier.verify(revisit.query, revisit.map, match);
    const std::string detail = VIMS_STR(
        "before: matches " << r_old.num_matches << ", inliers " << r_old.num_inliers << ", " << toString(r_old.stage)
                           << "; defaults: matches " << r.num_matches << ", inliers " << r.num_inliers
                           << ", tilt error " << r.tilt_error_deg << " deg, " << toString(r.stage));
    EXPECT_NE(r_old.stage, LoopStage::kAccepted) << detail << ": the test no longer captures the cause";
    EXPECT_EQ(r.stage, LoopStage::kAccepted) << detail;
    if (r.stage != LoopStage::kAccepted) continue;
    // 0.2 m / 3 deg: over a flat seabed 4 m below, a tilt and a lateral shift are nearly the same
    // image motion for PnP (2 deg ~ 0.14 m); vims_eval counts a loop correct within 0.5 m / 5 deg.
    expectPoseNear(r.T_match_query, revisit.poses[match].inverse() * revisit.T_w_bq, 0.2, 3.0);
  }
  // Without a common component (world heights not comparable) the window falls back to +-2.
  const LoopVerifier verifier(testLoopOptions(), world.camera());
  MultiScaleMap other(test::vocabulary("orb_k8l4.vocab"), PoseGraphOptions(), 0.0);
  const LevelWindow fallback = verifier.levelWindow(LoopQuery{}, other, 0);
  EXPECT_DOUBLE_EQ(fallback.shift, 0.0);
  EXPECT_DOUBLE_EQ(fallback.tolerance, testLoopOptions().match_max_level_difference);
}

// The query's seabed corners get their 3D points from the local inverse-depth plane of the
// tracked points: on the test world's flat seabed (z = 0) they must lie on it, in the VIO frame.
TEST(KeyframeDescriber, SeabedCornersLieOnTheSeabedAndAreDescribedOnCoarseLevels) {
  test::TestWorld world(kWorldSeed);
  const LoopDetectorOptions o;
  KeyframeDescriber describer(FeatureExtractionOptions(), o.harris_threshold, world.camera());
  const Eigen::Isometry3d T_w_b = bodyPose(3.0, -1.0, 3.2, 40.0, 2.0, -3.0);
  const Eigen::Isometry3d T_odom_w = yawTransform(25.0, Eigen::Vector3d(-2.0, 5.0, 1.0));
  const KeyframeData kf = world.trackerKeyframe(5.0, 0, T_w_b, T_odom_w * T_w_b, 7);
  const DescribedPoints tracked = describer.describePoints(kf.image, kf.features);
  const DescribedPoints seabed =
      describer.describeSeabedCorners(kf.image, tracked, kf.T_odom_b * world.camera().T_b_c, o.query_seabed_corners,
                                      o.submap_corner_min_distance_px, o.submap_corner_max_level);
  ASSERT_GT(seabed.numPoints(), 200u);
  double worst = 0.0;
  for (const Eigen::Vector3d& p_odom : seabed.p_odom)
    worst = std::max(worst, std::abs((T_odom_w.inverse() * p_odom).z()));
  EXPECT_LT(worst, 1e-3) << "a seabed corner off the seabed plane by " << worst << " m";
  for (const uint64_t id : seabed.feature_id) EXPECT_NE(id >> 63, 0u);
  for (const int level : seabed.level_of_descriptor) {
    EXPECT_GE(level, 1);
    EXPECT_LE(level, o.submap_corner_max_level);
  }
  // Too few tracked points to fit a plane: none.
  DescribedPoints few = tracked;
  few.p_odom.resize(KeyframeDescriber::kNeighbours - 1);
  few.pixel.resize(KeyframeDescriber::kNeighbours - 1);
  EXPECT_TRUE(describer.describeSeabedCorners(kf.image, few, kf.T_odom_b * world.camera().T_b_c, 400, 4.0, 3).empty());
}

// The same revisit reported with a magnetic signature unlike any submap's (the coil's field
// changes with height): the magnetic and BoW stages offer no candidate, and only the pose graph's
// estimate of where the query is (proximity_candidates) brings the old place to verification.
TEST(HierarchicalLoopDetector, ProximityCandidatesBringAPlaceTheOtherStagesMiss) {
  test::TestWorld world(kWorldSeed);
  LoopDetectorOptions o = testLoopOptions();
  AltitudeRevisit revisit(world, o, 2.5, 4.1);
  MagneticSubmapDraft d;
  d.tied_node = 3;
  d.signature_enu = Eigen::Vector3d(2.0e-6, -1.0e-6, 3.0e-6);
  d.radius_m = 1.0;
  revisit.map.addMagneticSubmap(d);
  revisit.query.signatures_enu = {{0, Eigen::Vector3d(-4.0e-6, 1.0e-6, 0.5e-6)}};
  const ModeSettings full = ModeSettings::forMode(LoopClosingMode::kFull);

  o.proximity_candidates = 0;
  const DetectionResult without =
      HierarchicalLoopDetector(o, MagneticSubmapOptions(), full, world.camera()).detect(revisit.query, revisit.map);
  EXPECT_FALSE(without.accepted);
  EXPECT_TRUE(without.bow_pool.empty());
  EXPECT_TRUE(without.proximity_candidates.empty());

  o.proximity_candidates = 1;
  const HierarchicalLoopDetector detector(o, MagneticSubmapOptions(), full, world.camera());
  const DetectionResult with = detector.detect(revisit.query, revisit.map);
  ASSERT_EQ(with.proximity_candidates.size(), 1u);
  // The nearest keyframe of the first visit to the query body (within the radius).
  const PoseGraphNodeId nearest = with.proximity_candidates[0];
  EXPECT_LT(nearest, 7u);
  EXPECT_LE((revisit.map.node(nearest).pose.p_w_b - revisit.T_w_bq.translation()).head<2>().norm(),
            o.proximity_radius_m);
  for (PoseGraphNodeId n = 0; n < 7; ++n)
    EXPECT_GE((revisit.map.node(n).pose.p_w_b - revisit.T_w_bq.translation()).head<2>().norm() + 1e-12,
              (revisit.map.node(nearest).pose.p_w_b - revisit.T_w_bq.translation()).head<2>().norm());
  ASSERT_TRUE(with.accepted);
  EXPECT_EQ(with.accepted->match_node, nearest);
  EXPECT_TRUE(with.accepted->proximity);
  expectPoseNear(with.accepted->T_match_query, revisit.poses[nearest].inverse() * revisit.T_w_bq, 0.2, 3.0);
  // Already verified by BoW: not proposed again.
  for (const PoseGraphNodeId n : detector.proximityCandidates(revisit.query, revisit.map, {0, 1, 2, 3, 4, 5, 6}))
    EXPECT_GE(n, 7u);
  // Outside the radius: nothing.
  o.proximity_radius_m = 0.01;
  EXPECT_TRUE(HierarchicalLoopDetector(o, MagneticSubmapOptions(), full, world.camera())
                  .proximityCandidates(revisit.query, revisit.map)
                  .empty());
}

}  // namespace
}  // namespace vims
