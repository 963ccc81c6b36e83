#pragma once
/// @file sim_truth.h
/// @brief What the simulator knows and the estimator must not: `<seq>_truth.yaml`.
///
/// Evaluation tools read it to score the coil localisation, the geomagnetic reference, the
/// camera time-delay estimate and the IMU bias estimates, and to know which spans had sensor
/// dropouts. The estimator never reads this file (sensor-contract.md).

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "vims_sim/magnetic_field.h"

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
};

struct SimTruth {
  std::string generator = "vims_sim";
  std::string scenario;            ///< "tank" or "field"
  std::string name;                ///< sequence name
  uint64_t trajectory_seed = 0;    ///< fixes the path, the rig calibration and all noise
  uint64_t world_seed = 0;         ///< fixes the seabed texture, the coil position and the site's field
  double start_time = 0.0;         ///< bag-clock time of the sequence start [s]
  double duration = 0.0;           ///< [s]
  double static_start = 0.0;       ///< [s] the vehicle is at rest from the start for this long
  double travel = 0.0;             ///< [m] designed horizontal path length travelled
  double camera_time_delay = 0.0;  ///< [s] image header.stamp = true exposure time + this

  /// The seabed coil. Its current is I(t) = current * sin(2 pi f (t - start_time) + phase).
  CoilDipole coil;
  GeomagneticField geomagnetic;

  /// IMU biases at the first sample (they then random-walk).
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();   ///< [rad/s]
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();  ///< [m/s^2]

  DropoutSpans dropouts;

  /// YAML text (numbers with round-trip precision).
  std::string toYaml() const;
  /// Writes the file; throws std::runtime_error on I/O failure.
  void save(const std::string& path) const;
  /// Reads a file written by save(). Throws vims::ConfigError naming the bad key (unknown keys,
  /// wrong types, a coil moment or field vector inconsistent with the other values).
  static SimTruth load(const std::string& path);
};

}  // namespace sim
}  // namespace vims
