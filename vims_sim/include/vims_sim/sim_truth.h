#pragma once
/// @file sim_truth.h
/// @brief What the simulator knows and the estimator must not: `<seq>_truth.yaml`.
///
/// Evaluation tools read it to score the coil localisation, the geomagnetic reference, the
/// camera time-delay estimate and the IMU bias estimates, to know which spans had sensor
/// dropouts, to rebuild the seabed (terrainFromTruth) and to know the water column of the
/// pressure sensor. The estimator never reads this file (sensor-contract.md).
///
/// Keys that only some sequences have (terrain, pressure, depth_hold_z, dropouts.pressure_off)
/// are written only when they are used, so a flat sequence without a pressure sensor has the
/// same file as before they existed, and such old files load (no terrain key: flat).

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vims_sim/magnetic_field.h"
#include "vims_sim/sensor_models.h"
#include "vims_sim/terrain.h"
#include "vims_sim/thruster_interference.h"

namespace vims {
namespace sim {

/// A time span [begin, end) in seconds from the sequence start.
struct TimeSpan {
  double begin = 0.0;
  double end = 0.0;
  bool contains(double t) const { return t >= begin && t < end; }
};

bool anySpanContains(const std::vector<TimeSpan>& spans, double t);

/// Sensor dropouts requested for a sequence (seconds from the sequence start; a sensor's
/// sample belongs to a span if its true sample time is inside).
struct DropoutSpans {
  std::vector<TimeSpan> camera_blackout;  ///< frames published but black (lamp failure)
  std::vector<TimeSpan> camera_off;       ///< no image messages
  std::vector<TimeSpan> sonar_off;        ///< no sonar messages
  std::vector<TimeSpan> mag_off;          ///< no magnetometer messages
  std::vector<TimeSpan> imu_gap;          ///< no IMU messages
  std::vector<TimeSpan> pressure_off;     ///< no pressure messages
};

/// The pressure sensor's world: the water column and the faults injected for testing.
struct PressureTruth {
  WaterColumn water;                  ///< surface height, true atmospheric pressure, density, gravity
  double atmospheric_error_pa = 0.0;  ///< <seq>.yaml's atmospheric_pa minus the true one
  double spike_fraction = 0.0;        ///< fraction of samples with a spike
  double spike_min_pa = 0.0;          ///< spike magnitude range (random sign)
  double spike_max_pa = 0.0;
};

/// An imperfect camera calibration: the sequence YAML's T_b_c is true_T_b_c turned and moved.
struct CameraExtrinsicError {
  double rotation_deg = 0.0;   ///< angle between the YAML's and the true camera rotation
  double translation_m = 0.0;  ///< distance between the YAML's and the true camera position
  Eigen::Isometry3d true_T_b_c = Eigen::Isometry3d::Identity();
};

/// A repeat mission over a saved map: what differs from the teach run besides the trajectory
/// seed (defaults: nothing). Where it starts on the lap and which way it flies it, its altitude,
/// the water and the lamp, and how much of the seabed changed since (the changed patches are the
/// dive's: trajectory seed). vims_sim --start-along-lap-m, --reverse-lap, --altitude-offset-m,
/// --turbidity, --lamp-power, --seabed-change.
struct MissionConditions {
  double start_along_lap_m = 0.0;  ///< [m] along the scenario's base lap
  bool reverse_lap = false;        ///< the lap flown the other way round
  double altitude_offset_m = 0.0;  ///< [m] added to the altitude profile
  double turbidity = 1.0;          ///< attenuation and backscatter build-up x this (1: clear water)
  double lamp_power = 1.0;         ///< lamp light x this, exposure unchanged
  double seabed_change = 0.0;      ///< fraction of the seabed re-laid since the survey

  bool isDefault() const;
};

struct SimTruth {
  std::string generator = "vims_sim";
  std::string scenario;            ///< "tank" or "field"
  std::string name;                ///< sequence name
  uint64_t trajectory_seed = 0;    ///< fixes the path, the rig calibration and all noise
  uint64_t world_seed = 0;         ///< fixes the seabed texture, the coil position and the site's field
  uint64_t rig_seed = 0;           ///< fixes the rig calibration (absent in older files: the trajectory seed)
  double start_time = 0.0;         ///< bag-clock time of the sequence start [s]
  double duration = 0.0;           ///< [s]
  double static_start = 0.0;       ///< [s] the vehicle is at rest from the start for this long
  double travel = 0.0;             ///< [m] designed horizontal path length travelled
  double camera_time_delay = 0.0;  ///< [s] image header.stamp = true exposure time + this

  /// The seabed coil (the first one of several). Its current is
  /// I(t) = current * sin(2 pi f (t - start_time) + phase).
  CoilDipole coil;
  /// The further coils (vims_sim --coil-frequencies), in the order of the sequence YAML's
  /// coil_frequency_hz list: its entry i (i >= 1) is other_coils[i - 1]. Empty: one coil.
  std::vector<CoilDipole> other_coils;
  GeomagneticField geomagnetic;
  /// Set when the site has a local anomaly of the geomagnetic field (vims_sim --magnetic-anomaly-ut).
  std::optional<MagneticAnomaly> magnetic_anomaly;
  /// Set when the vehicle's thrusters disturb the magnetometer (vims_sim --thrusters).
  std::optional<ThrusterInterference> thrusters;
  /// Set when the magnetometer is not calibrated (vims_sim --mag-hard-iron-ut, --mag-soft-iron-pct).
  std::optional<MagnetometerIron> magnetometer_iron;

  /// IMU biases at the first sample (they then random-walk).
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();   ///< [rad/s]
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();  ///< [m/s^2]

  DropoutSpans dropouts;

  TerrainParams terrain;                  ///< the seabed (flat unless the sequence had terrain)
  std::optional<PressureTruth> pressure;  ///< set when the sequence has a pressure sensor
  std::optional<double> depth_hold_z;     ///< [m] set when the vehicle held a constant z instead of its altitude
  bool hold_plane_only = false;           ///< the altitude hold followed the seabed's plane, not its relief
  MissionConditions mission;              ///< written only when not the default
  /// Set when the sequence YAML's T_b_c is not the true one (vims_sim --camera-extrinsic-error-*).
  std::optional<CameraExtrinsicError> camera_extrinsic_error;

  /// Number of coils (1 + other_coils.size()).
  int coilCount() const { return 1 + static_cast<int>(other_coils.size()); }
  /// The coil of index i in the sequence's list (0: `coil`, i: other_coils[i - 1]); nullptr when
  /// there is no such coil.
  const CoilDipole* coilAt(int i) const {
    if (i == 0) return &coil;
    return i > 0 && i < coilCount() ? &other_coils[static_cast<size_t>(i - 1)] : nullptr;
  }

  /// The field the magnetometer measures (without its noise).
  MagneticWorld magneticWorld() const {
    return MagneticWorld{geomagnetic.fieldEnu(), coil, magnetic_anomaly, other_coils};
  }

  /// The camera extrinsic the images were rendered with: the true one, or the YAML's `T_b_c`
  /// when the sequence has no calibration error.
  Eigen::Isometry3d trueCameraExtrinsic(const Eigen::Isometry3d& yaml_T_b_c) const {
    return camera_extrinsic_error ? camera_extrinsic_error->true_T_b_c : yaml_T_b_c;
  }

  /// YAML text (numbers with round-trip precision).
  std::string toYaml() const;
  /// Writes the file; throws std::runtime_error on I/O failure.
  void save(const std::string& path) const;
  /// Reads a file written by save(). Throws vims::ConfigError naming the bad key (unknown keys,
  /// wrong types, a coil moment, field vector or terrain wave list inconsistent with the other
  /// values). `other_coils` is optional (files of one coil have none).
  static SimTruth load(const std::string& path);
};

/// The seabed of a sequence, rebuilt from its truth (the same h(x, y) the simulator used).
SeabedTerrain terrainFromTruth(const SimTruth& truth);

}  // namespace sim
}  // namespace vims
