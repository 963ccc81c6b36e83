#pragma once
/// @file trajectory.h
/// @brief The simulated AUV motion: one analytic model for pose, velocity, acceleration and
/// body angular rate.
///
/// Design (see docs/simulator.md): a scenario's survey pattern (waypoints with rounded
/// corners, repeated in laps with seeded variation) is followed with a smooth speed profile
/// (cruise speed varying along the path, slower in turns, bounded longitudinal and lateral
/// acceleration) and an altitude profile between about 2 and 5 m above the large-scale seabed
/// (plane and rolling relief of the terrain; or a constant depth, see TrajectoryParams). That design is sampled once
/// per second into the control points of a quintic uniform B-spline for the position and one
/// for the Euler angles (yaw = path heading plus a small crab angle, gentle roll/pitch).
/// Everything sample() returns is the spline and its exact derivatives, so the IMU derived
/// from it integrates back to the same trajectory.

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vims_sim/bspline.h"
#include "vims_sim/terrain.h"

namespace vims {
namespace sim {

enum class Scenario { kTank, kField };

/// "tank" or "field".
std::string scenarioName(Scenario scenario);
/// Parses "tank" / "field"; throws std::invalid_argument otherwise.
Scenario parseScenario(const std::string& name);

/// Axis-aligned extent of a scenario's survey area in world ENU [m] (centred on the origin).
struct ScenarioArea {
  double half_size_x = 0.0;
  double half_size_y = 0.0;
};
ScenarioArea scenarioArea(Scenario scenario);

/// The base survey pattern of one lap (before the seeded per-lap variation), world ENU [m].
/// Successive laps follow it again; the lap ends near its start.
std::vector<Eigen::Vector2d> scenarioLapWaypoints(Scenario scenario);

/// One instant of the trajectory. All quantities are of the body (IMU) frame.
struct TrajectoryState {
  double t = 0.0;                                             ///< seconds from the sequence start
  Eigen::Vector3d p_w_b = Eigen::Vector3d::Zero();            ///< position in world ENU [m]
  Eigen::Vector3d v_w_b = Eigen::Vector3d::Zero();            ///< velocity in world [m/s]
  Eigen::Vector3d a_w_b = Eigen::Vector3d::Zero();            ///< acceleration in world [m/s^2]
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();  ///< orientation (body FLU in world)
  Eigen::Vector3d omega_b = Eigen::Vector3d::Zero();          ///< angular rate in body [rad/s]
};

struct TrajectoryParams {
  Scenario scenario = Scenario::kTank;
  double duration = 750.0;    ///< [s] sequence length; sample() is exact on [-margin, duration + margin]
  uint64_t seed = 1;          ///< trajectory seed: fixes the per-lap variation, speeds, attitude motion
  double static_start = 3.0;  ///< [s] the vehicle is exactly at rest on [-margin, static_start]
  double margin = 5.0;        ///< [s] extra time the model covers on both sides
  /// The seabed. Altitude hold (the default) flies the altitude profile above its large-scale
  /// shape (plane + rolling relief, not the roughness or the rocks); flat: above z = 0.
  TerrainParams terrain;
  /// Depth hold instead: the body stays at this constant world z [m] (the altitude then
  /// changes with the seabed).
  std::optional<double> depth_hold_z;
  /// Altitude hold follows the seabed's plane only, not its rolling relief (a slow altitude
  /// controller, or a vehicle told to keep its depth profile over small hills): the relief then
  /// changes the altitude, as depth hold does, while the vehicle still climbs with the slope.
  bool hold_plane_only = false;
  /// Where a mission starts and which way it flies the lap (a repeat mission of a saved map):
  /// the path starts this far [m] along the scenario's base lap (any value; taken modulo the
  /// lap's length), heading along it, ...
  double start_along_lap_m = 0.0;
  /// ... and flies the lap backwards (every leg the other way round).
  bool reverse_lap = false;
  /// Added to the altitude profile [m] (altitude hold; -1 to 3): a mission flown higher or lower.
  double altitude_offset_m = 0.0;
};

/// The base lap as a mission starting `start_along_m` along it (modulo its length) and flying
/// it backwards if `reverse`: the same closed pattern, other first waypoint and direction.
/// (0, false) returns `lap` itself.
std::vector<Eigen::Vector2d> missionLap(const std::vector<Eigen::Vector2d>& lap, double start_along_m, bool reverse);

class Trajectory {
 public:
  /// Designs the trajectory. Throws std::invalid_argument on bad parameters.
  static Trajectory design(const TrajectoryParams& params);

  /// Full state at time t (seconds from the sequence start); t is clamped to the valid range.
  TrajectoryState sample(double t) const;
  /// Pose only (cheaper): T_w_b.
  Eigen::Isometry3d pose(double t) const;

  double validBegin() const { return position_.validBegin(); }
  double validEnd() const { return position_.validEnd(); }
  const TrajectoryParams& params() const { return params_; }

  /// Time at which the designed path motion begins (the spline starts moving at static_start).
  double motionStart() const { return params_.static_start; }
  /// Length of the designed horizontal path actually travelled within [0, duration] [m].
  double designedTravel() const { return designed_travel_; }

  /// Orientation from Euler angles: R_w_b = Rz(yaw) Ry(pitch) Rx(roll).
  static Eigen::Quaterniond eulerToQuaternion(double yaw, double pitch, double roll);

 private:
  TrajectoryParams params_;
  UniformBSpline<3> position_;  ///< p_w_b
  UniformBSpline<3> euler_;     ///< (yaw, pitch, roll) [rad], yaw unwrapped
  double designed_travel_ = 0.0;
};

}  // namespace sim
}  // namespace vims
