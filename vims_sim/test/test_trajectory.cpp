// The trajectory model: B-spline basis, analytic derivative consistency, IMU integration back
// to the ground truth, the static start, the motion envelope, the revisit structure, and the
// vertical modes over terrain (altitude hold, depth hold).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "vims_sim/bspline.h"
#include "vims_sim/sensor_models.h"
#include "vims_sim/trajectory.h"

using namespace vims::sim;

namespace {

constexpr double kDeg = M_PI / 180.0;

Trajectory makeTrajectory(Scenario scenario, double duration, uint64_t seed, double static_start = 3.0) {
  TrajectoryParams p;
  p.scenario = scenario;
  p.duration = duration;
  p.seed = seed;
  p.static_start = static_start;
  return Trajectory::design(p);
}

Eigen::Vector3d rotationLog(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

Eigen::Matrix3d rotationExp(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

double headingOf(const TrajectoryState& s) { return std::atan2(s.v_w_b.y(), s.v_w_b.x()); }

}  // namespace

TEST(BSpline, BlendingMatrixMatchesTheKnownCubicAndSumsToOne) {
  const Eigen::MatrixXd cubic = UniformBSpline<1>::blendingMatrix(3);
  Eigen::MatrixXd expected(4, 4);
  expected << 1, -3, 3, -1, 4, 0, -6, 3, 1, 3, 3, -3, 0, 0, 0, 1;
  EXPECT_LT((cubic - expected / 6.0).norm(), 1e-12);
  for (int degree = 1; degree <= 6; ++degree) {
    const Eigen::MatrixXd m = UniformBSpline<1>::blendingMatrix(degree);
    // Partition of unity: the weights sum to 1 for every u (constant term 1, others 0).
    const Eigen::VectorXd column_sums = m.colwise().sum();
    EXPECT_NEAR(column_sums(0), 1.0, 1e-12) << "degree " << degree;
    for (int n = 1; n <= degree; ++n) EXPECT_NEAR(column_sums(n), 0.0, 1e-12) << "degree " << degree;
  }
}

TEST(BSpline, ReproducesAPolynomialOfItsDegreeAndItsDerivatives) {
  // A uniform quintic B-spline whose control points sample a quadratic at the centred times
  // reproduces a quadratic (exactly up to a constant shift), so its 2nd derivative is exact.
  std::vector<Eigen::Matrix<double, 1, 1>> control;
  const double dt = 0.5;
  for (int j = 0; j < 20; ++j) {
    const double tau = (j - 2) * dt;
    control.push_back(Eigen::Matrix<double, 1, 1>(3.0 * tau * tau - tau));
  }
  UniformBSpline<1> spline(5, 0.0, dt, control);
  Eigen::Matrix<double, 1, 1> out[3];
  for (double t = 0.1; t < 6.0; t += 0.37) {
    spline.evaluate(t, 2, out);
    EXPECT_NEAR(out[1](0), 6.0 * t - 1.0, 1e-9);
    EXPECT_NEAR(out[2](0), 6.0, 1e-9);
  }
}

TEST(Trajectory, AnalyticDerivativesMatchFiniteDifferences) {
  for (Scenario scenario : {Scenario::kTank, Scenario::kField}) {
    const Trajectory traj = makeTrajectory(scenario, 750.0, 11);
    const double h = 1e-3;
    double worst_v = 0, worst_a = 0, worst_w = 0;
    for (double t = 0.5; t < 749.0; t += 3.7) {
      const TrajectoryState s = traj.sample(t), sm = traj.sample(t - h), sp = traj.sample(t + h);
      worst_v = std::max(worst_v, (s.v_w_b - (sp.p_w_b - sm.p_w_b) / (2 * h)).norm());
      worst_a = std::max(worst_a, (s.a_w_b - (sp.v_w_b - sm.v_w_b) / (2 * h)).norm());
      // omega_b from the finite difference of the orientation: R(t-h)^T R(t+h) = Exp(2 h omega_b).
      const Eigen::Vector3d w_fd =
          rotationLog(sm.q_w_b.toRotationMatrix().transpose() * sp.q_w_b.toRotationMatrix()) / (2 * h);
      worst_w = std::max(worst_w, (s.omega_b - w_fd).norm());
      // pose() agrees with sample().
      const Eigen::Isometry3d T = traj.pose(t);
      ASSERT_LT((T.translation() - s.p_w_b).norm(), 1e-12);
      ASSERT_LT((T.linear() - s.q_w_b.toRotationMatrix()).norm(), 1e-12);
    }
    EXPECT_LT(worst_v, 1e-7) << scenarioName(scenario);
    EXPECT_LT(worst_a, 1e-7) << scenarioName(scenario);
    EXPECT_LT(worst_w, 1e-7) << scenarioName(scenario);
  }
}

// Midpoint (trapezoidal) integration of noiseless 200 Hz IMU samples from the true state.
double imuIntegrationDrift(const Trajectory& traj, double t_begin, double t_end, double* rotation_error) {
  const double g = 9.81, dt = 1.0 / 200.0;
  const Eigen::Vector3d g_w(0, 0, -g);
  TrajectoryState s = traj.sample(t_begin);
  Eigen::Matrix3d R = s.q_w_b.toRotationMatrix();
  Eigen::Vector3d v = s.v_w_b, p = s.p_w_b;
  Eigen::Vector3d f = ImuSimulator::idealSpecificForce(s, g), w = s.omega_b;
  double worst = 0.0;
  const int steps = static_cast<int>(std::lround((t_end - t_begin) / dt));
  for (int k = 1; k <= steps; ++k) {
    const TrajectoryState s1 = traj.sample(t_begin + k * dt);
    const Eigen::Vector3d f1 = ImuSimulator::idealSpecificForce(s1, g), w1 = s1.omega_b;
    const Eigen::Matrix3d R1 = R * rotationExp(0.5 * (w + w1) * dt);
    const Eigen::Vector3d a0 = R * f + g_w, a1 = R1 * f1 + g_w;
    const Eigen::Vector3d v1 = v + 0.5 * (a0 + a1) * dt;
    p += 0.5 * (v + v1) * dt;
    v = v1;
    R = R1;
    f = f1;
    w = w1;
    worst = std::max(worst, (p - s1.p_w_b).norm());
    *rotation_error = rotationLog(R.transpose() * s1.q_w_b.toRotationMatrix()).norm();
  }
  return worst;
}

TEST(Trajectory, NoiselessImuIntegratesBackToTheTrajectory) {
  const Trajectory tank = makeTrajectory(Scenario::kTank, 750.0, 3);
  double rotation_error = 0.0;
  EXPECT_LT(imuIntegrationDrift(tank, 0.0, 60.0, &rotation_error), 0.01);  // static start + acceleration
  EXPECT_LT(rotation_error, 1e-5);
  EXPECT_LT(imuIntegrationDrift(tank, 300.0, 360.0, &rotation_error), 0.01);  // turns and climbs
  EXPECT_LT(rotation_error, 1e-5);
  const Trajectory field = makeTrajectory(Scenario::kField, 600.0, 4);
  EXPECT_LT(imuIntegrationDrift(field, 200.0, 260.0, &rotation_error), 0.01);
  EXPECT_LT(rotation_error, 1e-5);
}

TEST(Trajectory, StaticStartIsExactlyAtRestThenMoves) {
  const Trajectory traj = makeTrajectory(Scenario::kTank, 60.0, 5, 4.0);
  const TrajectoryState s0 = traj.sample(0.0);
  for (double t = -2.0; t <= 4.0; t += 0.005) {
    const TrajectoryState s = traj.sample(t);
    ASSERT_EQ(s.v_w_b.norm(), 0.0) << t;
    ASSERT_EQ(s.a_w_b.norm(), 0.0) << t;
    ASSERT_EQ(s.omega_b.norm(), 0.0) << t;
    ASSERT_EQ((s.p_w_b - s0.p_w_b).norm(), 0.0) << t;
    // At rest the accelerometer reads +g along the world up axis.
    const Eigen::Vector3d f_w = s.q_w_b * ImuSimulator::idealSpecificForce(s, 9.81);
    ASSERT_LT((f_w - Eigen::Vector3d(0, 0, 9.81)).norm(), 1e-12);
  }
  EXPECT_GT(traj.sample(4.5).v_w_b.norm(), 0.0);
  EXPECT_GT(traj.sample(20.0).v_w_b.norm(), 0.05);
}

TEST(Trajectory, ShortSequenceIsTheStartOfTheLongOne) {
  const Trajectory short_traj = makeTrajectory(Scenario::kTank, 60.0, 9);
  const Trajectory long_traj = makeTrajectory(Scenario::kTank, 750.0, 9);
  for (double t = 0.0; t < 60.0; t += 0.25) {
    const TrajectoryState a = short_traj.sample(t), b = long_traj.sample(t);
    ASSERT_LT((a.p_w_b - b.p_w_b).norm(), 1e-9) << t;
    ASSERT_LT(a.q_w_b.angularDistance(b.q_w_b), 1e-9) << t;
  }
  const Trajectory other = makeTrajectory(Scenario::kTank, 60.0, 10);
  EXPECT_GT((other.sample(59.0).p_w_b - short_traj.sample(59.0).p_w_b).norm(), 0.05);
}

struct Envelope {
  double max_speed = 0, accel_p95 = 0, min_alt = 1e9, max_alt = -1e9, max_tilt = 0, travel = 0;
  Eigen::Vector2d min_xy{1e9, 1e9}, max_xy{-1e9, -1e9};
};

Envelope envelopeOf(const Trajectory& traj, double duration) {
  Envelope e;
  std::vector<double> accel;
  Eigen::Vector3d previous = traj.sample(0.0).p_w_b;
  for (double t = 0.0; t < duration; t += 0.1) {
    const TrajectoryState s = traj.sample(t);
    e.max_speed = std::max(e.max_speed, s.v_w_b.norm());
    accel.push_back(s.a_w_b.norm());
    e.min_alt = std::min(e.min_alt, s.p_w_b.z());
    e.max_alt = std::max(e.max_alt, s.p_w_b.z());
    const Eigen::Vector3d up_b = s.q_w_b.conjugate() * Eigen::Vector3d::UnitZ();
    e.max_tilt = std::max(e.max_tilt, std::acos(std::min(1.0, up_b.z())));
    e.travel += (s.p_w_b - previous).head<2>().norm();
    previous = s.p_w_b;
    e.min_xy = e.min_xy.cwiseMin(s.p_w_b.head<2>());
    e.max_xy = e.max_xy.cwiseMax(s.p_w_b.head<2>());
  }
  std::sort(accel.begin(), accel.end());
  e.accel_p95 = accel[accel.size() * 95 / 100];
  return e;
}

TEST(Trajectory, TankMotionEnvelopeMatchesTheReferenceTankTest) {
  for (uint64_t seed : {1, 2, 3}) {
    const Envelope e = envelopeOf(makeTrajectory(Scenario::kTank, 750.0, seed), 750.0);
    EXPECT_LE(e.max_speed, 0.40) << seed;
    EXPECT_GE(e.max_speed, 0.30) << seed;
    EXPECT_LT(e.accel_p95, 0.05) << seed;
    EXPECT_GT(e.min_alt, 1.9) << seed;
    EXPECT_LT(e.max_alt, 5.1) << seed;
    EXPECT_GT(e.max_alt - e.min_alt, 1.5) << seed;  // the altitude really varies
    EXPECT_LT(e.max_tilt, 8.0 * kDeg) << seed;      // roll and pitch of a few degrees
    EXPECT_NEAR(e.travel, 130.0, 10.0) << seed;
    EXPECT_GT(e.min_xy.minCoeff(), -10.0) << seed;
    EXPECT_LT(e.max_xy.maxCoeff(), 10.0) << seed;
  }
}

TEST(Trajectory, FieldCoversALargerAreaWithLongTransits) {
  const Envelope e = envelopeOf(makeTrajectory(Scenario::kField, 1500.0, 1), 1500.0);
  EXPECT_LE(e.max_speed, 0.40);
  EXPECT_LT(e.accel_p95, 0.05);
  EXPECT_GT(e.min_alt, 1.9);
  EXPECT_LT(e.max_alt, 5.1);
  EXPECT_GT(e.travel, 350.0);
  EXPECT_GT(e.max_xy.x() - e.min_xy.x(), 60.0);
  EXPECT_GT(e.max_xy.y() - e.min_xy.y(), 40.0);
  EXPECT_LT(e.max_xy.maxCoeff(), 40.0);
  EXPECT_GT(e.min_xy.minCoeff(), -40.0);
}

TEST(Trajectory, TankRevisitsPlacesCrossingAndInOppositeDirection) {
  const Trajectory traj = makeTrajectory(Scenario::kTank, 750.0, 7);
  std::vector<TrajectoryState> samples;
  for (double t = 5.0; t < 750.0; t += 1.0) {
    const TrajectoryState s = traj.sample(t);
    if (s.v_w_b.head<2>().norm() > 0.05) samples.push_back(s);
  }
  int crossings = 0, opposite = 0;
  for (size_t i = 0; i < samples.size(); ++i) {
    for (size_t j = i + 1; j < samples.size(); ++j) {
      if (samples[j].t - samples[i].t < 60.0) continue;
      if ((samples[i].p_w_b - samples[j].p_w_b).head<2>().norm() > 1.0) continue;
      double dh = std::abs(std::remainder(headingOf(samples[i]) - headingOf(samples[j]), 2.0 * M_PI));
      if (dh > 70 * kDeg && dh < 110 * kDeg) ++crossings;
      if (dh > 160 * kDeg) ++opposite;
    }
  }
  EXPECT_GE(crossings, 5);
  EXPECT_GE(opposite, 3);
}

namespace {

TrajectoryParams terrainTrajectoryParams(Scenario scenario, double duration, uint64_t seed,
                                         const TerrainParams& terrain) {
  TrajectoryParams p;
  p.scenario = scenario;
  p.duration = duration;
  p.seed = seed;
  p.terrain = terrain;
  return p;
}

TerrainParams hillyTerrain(double slope_deg) {
  TerrainParams t;
  t.slope_deg = slope_deg;
  t.slope_azimuth_deg = 110.0;
  t.relief_m = 1.0;
  t.relief_wavelength_m = 30.0;
  t.roughness_m = 0.05;
  t.rock_height_m = 0.3;
  t.rock_density = 0.05;
  t.seed = 77;
  return t;
}

}  // namespace

// Altitude hold: the designed height is the large-scale seabed (plane + relief) plus the
// altitude profile, so the altitude above it stays in the profile's range; the hull pitches
// with the climb; the IMU still integrates back exactly.
TEST(Trajectory, AltitudeHoldFollowsTheLargeScaleSeabed) {
  for (const auto& [scenario, slope] : {std::make_pair(Scenario::kTank, 4.0), std::make_pair(Scenario::kField, 8.0)}) {
    const TerrainParams terrain_params = hillyTerrain(slope);
    const Trajectory traj = Trajectory::design(terrainTrajectoryParams(scenario, 750.0, 5, terrain_params));
    const SeabedTerrain terrain(terrain_params);
    double min_alt = 1e9, max_alt = -1e9, min_clearance = 1e9, min_z = 1e9, max_z = -1e9, pitch_climb = 0.0;
    for (double t = 0.0; t < 750.0; t += 0.1) {
      const TrajectoryState s = traj.sample(t);
      const double altitude = s.p_w_b.z() - terrain.largeScale(s.p_w_b.x(), s.p_w_b.y());
      min_alt = std::min(min_alt, altitude);
      max_alt = std::max(max_alt, altitude);
      min_clearance = std::min(min_clearance, s.p_w_b.z() - terrain.height(s.p_w_b.x(), s.p_w_b.y()));
      min_z = std::min(min_z, s.p_w_b.z());
      max_z = std::max(max_z, s.p_w_b.z());
      // The nose rises with the climb (pitch about +y of FLU is nose-down, pitch = trim - 0.2 climb).
      const Eigen::Vector3d forward = s.q_w_b * Eigen::Vector3d::UnitX();
      pitch_climb += std::asin(forward.z()) * s.v_w_b.z();
    }
    std::cout << scenarioName(scenario) << " over " << slope << " deg + 1 m relief: altitude above the large scale "
              << min_alt << " .. " << max_alt << " m, above the full terrain >= " << min_clearance << " m, z " << min_z
              << " .. " << max_z << " m\n";
    EXPECT_GT(min_alt, 1.9) << scenarioName(scenario);
    EXPECT_LT(max_alt, 5.1) << scenarioName(scenario);
    EXPECT_GT(min_clearance, 1.2) << scenarioName(scenario);
    EXPECT_GT(max_z - min_z, 4.0) << scenarioName(scenario);  // it really follows the seabed
    EXPECT_GT(pitch_climb, 0.0) << scenarioName(scenario);    // nose up while climbing
  }
  double rotation_error = 0.0;
  const Trajectory field = Trajectory::design(terrainTrajectoryParams(Scenario::kField, 600.0, 4, hillyTerrain(8.0)));
  EXPECT_LT(imuIntegrationDrift(field, 200.0, 260.0, &rotation_error), 0.01);
  EXPECT_LT(rotation_error, 1e-5);
}

// --hold-plane-only: the designed height follows the plane, so the altitude above the plane is
// the profile, and against the default altitude hold of the same seed the vehicle flies lower by
// exactly the relief under it (to the spline's smoothing): the relief passes under it unfollowed.
TEST(Trajectory, HoldPlaneOnlyLeavesTheReliefUnfollowed) {
  TrajectoryParams p = terrainTrajectoryParams(Scenario::kField, 600.0, 4, hillyTerrain(4.0));
  const Trajectory follows = Trajectory::design(p);
  p.hold_plane_only = true;
  const Trajectory traj = Trajectory::design(p);
  const SeabedTerrain terrain(p.terrain);
  double min_plane = 1e9, max_plane = -1e9, max_relief = 0.0, max_difference_error = 0.0;
  for (double t = 0.0; t < 600.0; t += 0.1) {
    const Eigen::Vector3d x = traj.sample(t).p_w_b;
    const double above_plane = x.z() - terrain.planeHeight(x.x(), x.y());
    min_plane = std::min(min_plane, above_plane);
    max_plane = std::max(max_plane, above_plane);
    const double relief = terrain.largeScale(x.x(), x.y()) - terrain.planeHeight(x.x(), x.y());
    max_relief = std::max(max_relief, std::abs(relief));
    ASSERT_LT((follows.sample(t).p_w_b.head<2>() - x.head<2>()).norm(), 1e-9) << t;  // the same path
    max_difference_error = std::max(max_difference_error, std::abs(follows.sample(t).p_w_b.z() - x.z() - relief));
  }
  EXPECT_GT(min_plane, 1.9);  // the profile's range (2.1-4.9 m) above the plane
  EXPECT_LT(max_plane, 5.1);
  EXPECT_GT(max_relief, 0.5);  // hillyTerrain's 1 m relief passes under the vehicle
  EXPECT_LT(max_difference_error, 0.05) << "the default hold follows the relief, the plane-only hold does not";
  double rotation_error = 0.0;
  EXPECT_LT(imuIntegrationDrift(traj, 200.0, 260.0, &rotation_error), 0.01);
  EXPECT_LT(rotation_error, 1e-5);
}

TEST(Trajectory, DepthHoldKeepsAConstantHeight) {
  TrajectoryParams p = terrainTrajectoryParams(Scenario::kTank, 300.0, 6, hillyTerrain(4.0));
  p.depth_hold_z = 4.5;
  const Trajectory traj = Trajectory::design(p);
  for (double t = 0.0; t < 300.0; t += 0.5) {
    const TrajectoryState s = traj.sample(t);
    ASSERT_NEAR(s.p_w_b.z(), 4.5, 1e-12) << t;
    ASSERT_NEAR(s.v_w_b.z(), 0.0, 1e-12) << t;
  }
  // The flat default is the plain altitude profile.
  TrajectoryParams flat = p;
  flat.terrain = TerrainParams();
  flat.depth_hold_z.reset();
  TrajectoryParams plain;
  plain.scenario = Scenario::kTank;
  plain.duration = 300.0;
  plain.seed = 6;
  const Trajectory a = Trajectory::design(flat), b = Trajectory::design(plain);
  for (double t = 0.0; t < 300.0; t += 1.3) ASSERT_EQ(a.sample(t).p_w_b, b.sample(t).p_w_b);
}

TEST(Trajectory, ARepeatMissionStartsElsewhereOnTheSameLapAndFliesItEitherWay) {
  const std::vector<Eigen::Vector2d> lap = scenarioLapWaypoints(Scenario::kTank);
  EXPECT_EQ(missionLap(lap, 0.0, false), lap);
  auto closedLength = [](const std::vector<Eigen::Vector2d>& w) {
    double length = 0.0;
    for (size_t i = 0; i < w.size(); ++i) length += (w[(i + 1) % w.size()] - w[i]).norm();
    return length;
  };
  auto distanceToLap = [&](const Eigen::Vector2d& p) {
    double best = 1e9;
    for (size_t i = 0; i < lap.size(); ++i) {
      const Eigen::Vector2d a = lap[i], b = lap[(i + 1) % lap.size()];
      const double u = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      best = std::min(best, (a + u * (b - a) - p).norm());
    }
    return best;
  };
  const double length = closedLength(lap);
  for (bool reverse : {false, true}) {
    for (double start : {0.0, 17.3, 40.0, length + 5.0}) {
      const auto mission = missionLap(lap, start, reverse);
      EXPECT_NEAR(closedLength(mission), length, 1e-9) << start << " " << reverse;
      for (const auto& w : mission) EXPECT_LT(distanceToLap(w), 1e-9);
    }
  }
  // Starting 5 m along the first leg (west to east at y = -6.3), forwards and backwards.
  EXPECT_LT((missionLap(lap, 5.0, false)[0] - (lap[0] + Eigen::Vector2d(5.0, 0.0))).norm(), 1e-9);
  EXPECT_GT(missionLap(lap, 5.0, false)[1].x(), lap[0].x() + 5.0);

  TrajectoryParams p;
  p.duration = 120.0;
  p.seed = 4;
  const Trajectory base = Trajectory::design(p);
  p.start_along_lap_m = 40.0;
  p.reverse_lap = true;
  p.altitude_offset_m = 1.5;
  const Trajectory repeat = Trajectory::design(p);
  const auto mission = missionLap(lap, 40.0, true);
  const TrajectoryState at_rest = repeat.sample(0.0);
  EXPECT_LT((at_rest.p_w_b.head<2>() - mission[0]).norm(), 1e-6);
  EXPECT_GT((at_rest.p_w_b.head<2>() - base.sample(0.0).p_w_b.head<2>()).norm(), 5.0);
  // It sets off along its first leg.
  const Eigen::Vector2d leg = (mission[1] - mission[0]).normalized();
  const TrajectoryState moving = repeat.sample(15.0);
  EXPECT_GT(moving.v_w_b.head<2>().normalized().dot(leg), std::cos(20.0 * kDeg));
  // The altitude profile is the base one raised by the offset (same seed, same arc lengths).
  TrajectoryParams level = p;
  level.altitude_offset_m = 0.0;
  const Trajectory unraised = Trajectory::design(level);
  for (double t : {0.0, 30.0, 77.0, 119.0})
    EXPECT_NEAR(repeat.sample(t).p_w_b.z() - unraised.sample(t).p_w_b.z(), 1.5, 1e-9) << t;
  p.altitude_offset_m = 3.5;
  EXPECT_THROW(Trajectory::design(p), std::invalid_argument);
}
