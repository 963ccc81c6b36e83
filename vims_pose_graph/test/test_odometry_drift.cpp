// The VIO's drift learnt from the loops (odometry_drift.h): a circling vehicle whose odometry
// drifts by a known amount, revisits closed by loops, and the fitted variance multipliers.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/multiscale_map.h"
#include "vims_pose_graph/odometry_drift.h"

namespace vims {
namespace {

constexpr double kDeg = M_PI / 180.0;

/// Laps of a 10 m radius circle, a keyframe every 0.3 m, with odometry edges drawn from the
/// configured noise model scaled by `truth`, and loops (5 consecutive keyframes per revisit
/// event) between the same places of consecutive laps at `event_angles_deg`.
struct CirclingRun {
  std::vector<SequentialEdge> edges;
  std::vector<LoopEdge> loops;
  PoseGraphOptions options;
  size_t events = 0;
  int per_lap = 0;  ///< keyframes per lap
};

CirclingRun circlingRun(const OdometryDriftScale& truth, int laps, const std::vector<double>& event_angles_deg,
                        unsigned seed) {
  CirclingRun run;
  run.options.learn_odometry_drift = true;
  const double radius = 10.0;
  const double step = 0.3;
  const int per_lap = static_cast<int>(std::round(2.0 * M_PI * radius / step));
  run.per_lap = per_lap;
  const int n = laps * per_lap + 1;
  std::vector<Eigen::Vector3d> p(n);
  std::vector<double> yaw(n);
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / per_lap;
    p[i] = Eigen::Vector3d(radius * std::cos(a), radius * std::sin(a), -0.02 * i / per_lap);
    yaw[i] = wrapAngle(a + M_PI / 2);
  }
  const auto relative = [&](int i, int j) {
    RelativePose4Dof z;
    z.p_li_j = rotationZ(yaw[i]).transpose() * (p[j] - p[i]);
    z.yaw_i_j = wrapAngle(yaw[j] - yaw[i]);
    return z;
  };
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i + 1 < n; ++i) {
    SequentialEdge e;
    e.from = static_cast<PoseGraphNodeId>(i);
    e.to = static_cast<PoseGraphNodeId>(i + 1);
    e.measurement = relative(i, i + 1);
    const Eigen::Vector4d sigma = sequentialEdgeSqrtInformation(run.options, e.measurement, truth).cwiseInverse();
    for (int k = 0; k < 3; ++k) e.measurement.p_li_j[k] += sigma[k] * unit(rng);
    e.measurement.yaw_i_j += sigma[3] * unit(rng);
    e.sqrt_information = sequentialEdgeSqrtInformation(run.options, e.measurement);
    run.edges.push_back(e);
  }
  const double loop_sigma_p = 0.01, loop_sigma_yaw = 0.1 * kDeg;
  for (int lap = 1; lap < laps; ++lap) {
    for (double angle : event_angles_deg) {
      const int m0 = (lap - 1) * per_lap + static_cast<int>(std::round(angle / 360.0 * per_lap));
      for (int k = 0; k < 5; ++k) {
        LoopEdge loop;
        loop.id = static_cast<LoopEdgeId>(run.loops.size());
        loop.match = static_cast<PoseGraphNodeId>(m0 + k);
        loop.query = static_cast<PoseGraphNodeId>(m0 + k + per_lap);
        loop.measurement = relative(m0 + k, m0 + k + per_lap);
        for (int c = 0; c < 3; ++c) loop.measurement.p_li_j[c] += loop_sigma_p * unit(rng);
        loop.measurement.yaw_i_j += loop_sigma_yaw * unit(rng);
        loop.sqrt_information << 1 / loop_sigma_p, 1 / loop_sigma_p, 1 / loop_sigma_p, 1 / loop_sigma_yaw;
        run.loops.push_back(loop);
      }
      ++run.events;
    }
  }
  return run;
}

TEST(OdometryDrift, SqrtInformationFollowsTheConfiguredShapeAndTheScale) {
  PoseGraphOptions o;
  RelativePose4Dof z;
  z.p_li_j = Eigen::Vector3d(0.3, 0.4, 0.0);  // d = 0.5 m
  const Eigen::Vector4d w = sequentialEdgeSqrtInformation(o, z);
  EXPECT_NEAR(1.0 / w[0], std::hypot(o.odometry_position_sigma_m, 0.5 * o.odometry_position_sigma_per_m), 1e-15);
  EXPECT_NEAR(1.0 / w[3], std::hypot(o.odometry_yaw_sigma_rad, 0.5 * o.odometry_yaw_sigma_per_m_rad), 1e-15);
  const Eigen::Vector4d scaled = sequentialEdgeSqrtInformation(o, z, OdometryDriftScale{0.04, 0.25});
  EXPECT_NEAR(scaled[1], w[1] / 0.2, 1e-9);
  EXPECT_NEAR(scaled[3], w[3] / 0.5, 1e-9);
}

TEST(OdometryDrift, TheFitFindsTheDriftTheOdometryHad) {
  // Drift well below the configured sigmas (as on the project's tank sequences), in position and
  // yaw by different amounts, 28 events (7 laps, 4 places). Seed 7 gives 1.19x / 1.05x and
  // 1.19x / 1.00x of the truth; seeds 1-8 0.45x-1.5x, the scatter of 28 draws of a variance.
  for (const OdometryDriftScale truth : {OdometryDriftScale{0.01, 0.04}, OdometryDriftScale{0.1, 0.2}}) {
    const CirclingRun run = circlingRun(truth, 8, {0.0, 90.0, 180.0, 270.0}, 7);
    const OdometryDriftFit fit = fitOdometryDrift(run.edges, run.loops, run.options);
    ASSERT_TRUE(fit.fitted);
    EXPECT_EQ(fit.loops_with_chain, run.loops.size());
    EXPECT_EQ(fit.chains_used, run.events);  // each event's five loops are one chain
    EXPECT_EQ(fit.chains_rejected, 0u);
    EXPECT_NEAR(fit.mean_chain_length_m, 2 * M_PI * 10.0, 1.0);
    EXPECT_GT(fit.scale.position, truth.position / 2) << truth.position;
    EXPECT_LT(fit.scale.position, truth.position * 2) << truth.position;
    EXPECT_GT(fit.scale.yaw, truth.yaw / 2) << truth.yaw;
    EXPECT_LT(fit.scale.yaw, truth.yaw * 2) << truth.yaw;
  }
}

TEST(OdometryDrift, AWrongLoopIsRejectedAndDoesNotLoosenTheFit) {
  const OdometryDriftScale truth{0.01, 0.04};
  CirclingRun run = circlingRun(truth, 8, {0.0, 180.0}, 7);
  const OdometryDriftFit clean = fitOdometryDrift(run.edges, run.loops, run.options);
  LoopEdge wrong = run.loops[12];  // a loop of a place 90 deg round the circle from the others
  wrong.id = static_cast<LoopEdgeId>(run.loops.size());
  const int per_lap = run.per_lap;
  wrong.match = static_cast<PoseGraphNodeId>(per_lap / 4);
  wrong.query = static_cast<PoseGraphNodeId>(per_lap / 4 + per_lap);
  wrong.measurement.p_li_j += Eigen::Vector3d(1.5, -1.0, 0.0);  // a plausible place 1.8 m off
  run.loops.push_back(wrong);
  const OdometryDriftFit fit = fitOdometryDrift(run.edges, run.loops, run.options);
  ASSERT_TRUE(fit.fitted);
  EXPECT_EQ(fit.chains_rejected, 1u);
  EXPECT_EQ(fit.chains_used, run.events);
  EXPECT_DOUBLE_EQ(fit.scale.position, clean.scale.position);
  EXPECT_DOUBLE_EQ(fit.scale.yaw, clean.scale.yaw);
}

TEST(OdometryDrift, TooFewEventsOrNoChainLeaveTheConfiguredSigmas) {
  CirclingRun run = circlingRun(OdometryDriftScale{0.01, 0.04}, 3, {0.0}, 3);  // 2 events
  OdometryDriftFit fit = fitOdometryDrift(run.edges, run.loops, run.options);
  EXPECT_FALSE(fit.fitted);
  EXPECT_EQ(fit.chains_used, 0u);
  EXPECT_EQ(fit.scale.position, 1.0);
  EXPECT_EQ(fit.scale.yaw, 1.0);
  run.options.odometry_drift_min_chains = 2;
  EXPECT_TRUE(fitOdometryDrift(run.edges, run.loops, run.options).fitted);
  // A gap in the chain (a VIO reset between the keyframes): the loops across it have no chain.
  run.edges.erase(run.edges.begin() + 100);
  fit = fitOdometryDrift(run.edges, run.loops, run.options);
  EXPECT_EQ(fit.loops_with_chain, 5u);  // the second event's loops start after the gap
  EXPECT_FALSE(fit.fitted);
  // Disabled loops do not count.
  for (LoopEdge& loop : run.loops) loop.enabled = false;
  EXPECT_EQ(fitOdometryDrift(run.edges, run.loops, run.options).loops_with_chain, 0u);
}

TEST(OdometryDrift, TheEstimatorRefitsOnlyForANewEvent) {
  const CirclingRun run = circlingRun(OdometryDriftScale{0.01, 0.04}, 5, {0.0, 180.0}, 11);
  OdometryDriftEstimator estimator(run.options);
  std::vector<LoopEdge> loops;
  for (size_t k = 0; k < run.loops.size(); ++k) {
    loops.push_back(run.loops[k]);
    const OdometryDriftFit fit = estimator.update(run.edges, loops);
    EXPECT_EQ(fit.loops_with_chain, loops.size());
    EXPECT_EQ(fit.fitted, k / 5 + 1 >= 3u) << k;  // 5 loops per event, 3 events needed
  }
  const OdometryDriftFit direct = fitOdometryDrift(run.edges, run.loops, run.options);
  EXPECT_EQ(estimator.fit().scale.position, direct.scale.position);
  EXPECT_EQ(estimator.fit().scale.yaw, direct.scale.yaw);
}

TEST(OdometryDrift, TheMapReweighsThisRunsEdgesAndTheOnesAddedLater) {
  // A noiseless VIO on three laps of a circle and loops at two places per lap: the drift is
  // below anything the bounds allow, so the fit ends at the lower bound.
  PoseGraphOptions options;
  options.learn_odometry_drift = true;
  options.odometry_drift_min_chains = 3;
  MultiScaleMap map(nullptr, options, 0.0);
  const uint32_t session = map.addSession(0, false);
  const int per_lap = 100;
  const auto pose = [&](int i) {
    const double a = 2.0 * M_PI * i / per_lap;
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = rotationZ(a + M_PI / 2);
    T.translation() = Eigen::Vector3d(5.0 * std::cos(a), 5.0 * std::sin(a), 0.0);
    return T;
  };
  const auto addKeyframe = [&](int i) {
    const Eigen::Isometry3d T = pose(i);
    const PoseGraphNodeId id =
        map.addNode(0.1 * i, session, T, T.translation(), std::atan2(T(1, 0), T(0, 0)), VisualSubmap(), false);
    if (i > 0) map.addSequentialEdge(id - 1, id);
  };
  for (int i = 0; i <= 3 * per_lap; ++i) addKeyframe(i);
  for (int lap = 1; lap < 3; ++lap)
    for (int place : {0, per_lap / 2}) {
      const int m = (lap - 1) * per_lap + place;
      map.addLoopEdge(static_cast<PoseGraphNodeId>(m), static_cast<PoseGraphNodeId>(m + per_lap),
                      pose(m).inverse() * pose(m + per_lap));
    }
  const Eigen::Vector4d before = map.sequentialEdges()[10].sqrt_information;
  const OdometryDriftFit& fit = map.learnOdometryDrift();
  ASSERT_TRUE(fit.fitted);
  EXPECT_EQ(fit.chains_used, 4u);
  EXPECT_DOUBLE_EQ(fit.scale.position, options.odometry_drift_scale_min);
  EXPECT_DOUBLE_EQ(fit.scale.yaw, options.odometry_drift_scale_min);
  const double factor = 1.0 / std::sqrt(options.odometry_drift_scale_min);
  EXPECT_NEAR(map.sequentialEdges()[10].sqrt_information[0], before[0] * factor, 1e-9 * factor);
  EXPECT_NEAR(map.sequentialEdges()[10].sqrt_information[3], before[3] * factor, 1e-9 * factor);
  addKeyframe(3 * per_lap + 1);
  EXPECT_NEAR(map.sequentialEdges().back().sqrt_information[0], before[0] * factor, 1e-9 * factor);
}

}  // namespace
}  // namespace vims
