#pragma once
/// @file sensor_models.h
/// @brief Noise models of the IMU, the single-beam sonar altimeter, the magnetometer and the
/// pressure (depth) sensor.
/// Each simulator owns its own random stream, so switching one sensor off (or changing its
/// dropout spans) never changes another sensor's noise.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>

#include "vims_sim/magnetic_field.h"
#include "vims_sim/random.h"
#include "vims_sim/terrain.h"
#include "vims_sim/thruster_interference.h"
#include "vims_sim/trajectory.h"

namespace vims {
namespace sim {

// ---------------------------------------------------------------------------------------------
// IMU
// ---------------------------------------------------------------------------------------------

/// Continuous-time IMU noise (Kalibr/Allan convention) and rate.
struct ImuNoiseParams {
  double rate_hz = 200.0;
  double gyro_noise_density = 0.0;      ///< rad/s/sqrt(Hz)
  double gyro_random_walk = 0.0;        ///< rad/s^2/sqrt(Hz)
  double accel_noise_density = 0.0;     ///< m/s^2/sqrt(Hz)
  double accel_random_walk = 0.0;       ///< m/s^3/sqrt(Hz)
  double gravity = 9.81;                ///< m/s^2
  double gyro_initial_bias_std = 0.0;   ///< rad/s, per axis, of the seeded turn-on bias
  double accel_initial_bias_std = 0.0;  ///< m/s^2, per axis

  /// An Xsens MTi-630 class unit: gyro 0.007 deg/s/sqrt(Hz), accelerometer 60 ug/sqrt(Hz);
  /// random walks that reproduce the datasheet in-run bias stability (gyro 8 deg/h,
  /// accelerometer 10 ug) at an Allan averaging time of about 300 s, using the rate random walk
  /// Allan deviation K sqrt(tau / 3); small turn-on biases (0.05 deg/s, 1.5 mg).
  static ImuNoiseParams mti630();
};

struct ImuMeasurement {
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();       ///< rad/s, body
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();      ///< m/s^2 specific force, body
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();  ///< the bias included in this sample
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
};

class ImuSimulator {
 public:
  ImuSimulator(const ImuNoiseParams& params, const Eigen::Vector3d& gyro_bias, const Eigen::Vector3d& accel_bias,
               uint64_t seed);

  /// Noise-free specific force f_b = R_w_b^T (a_w - g_w) with g_w = (0, 0, -g): about +g on the
  /// up axis at rest.
  static Eigen::Vector3d idealSpecificForce(const TrajectoryState& state, double gravity);

  /// One sample at the state's time: ideal values + current bias + white noise (discrete
  /// std = density * sqrt(rate)). Then the biases take one random-walk step (std = walk /
  /// sqrt(rate)). Call once per IMU period, including periods whose message is dropped.
  ImuMeasurement measure(const TrajectoryState& state);

  const ImuNoiseParams& params() const { return params_; }

 private:
  ImuNoiseParams params_;
  Eigen::Vector3d gyro_bias_, accel_bias_;
  Rng rng_;
};

// ---------------------------------------------------------------------------------------------
// Sonar altimeter
// ---------------------------------------------------------------------------------------------

struct SonarParams {
  double rate_hz = 10.0;
  double range_noise_std = 0.02;      ///< [m] white noise of a good echo
  double outlier_probability = 0.03;  ///< multipath: the range is multiplied by U(outlier_min, outlier_max)
  double outlier_min_factor = 1.3;
  double outlier_max_factor = 2.0;
  double dropout_probability = 0.01;  ///< no echo: range = +inf
  double min_range = 0.1;             ///< [m]
  double max_range = 50.0;            ///< [m] beyond: no echo (+inf)
  double field_of_view = 0.1;         ///< [rad] full beam width (reported in the message)
};

struct SonarReading {
  enum class Kind { kGood, kOutlier, kDropout, kOutOfRange };
  double range = 0.0;       ///< measured [m]; +inf for a dropout or no echo
  double true_range = 0.0;  ///< along the beam to the seabed [m]; +inf when the beam misses it
  Kind kind = Kind::kGood;
};

class SonarSimulator {
 public:
  /// `terrain`: the seabed the beam meets; null or flat: the plane z = 0.
  SonarSimulator(const SonarParams& params, const Eigen::Isometry3d& T_b_s, uint64_t seed,
                 std::shared_ptr<const SeabedTerrain> terrain = nullptr);

  /// Slant range from the sonar origin along its +z axis to the seabed z = 0 (+inf if the beam
  /// points upwards or is parallel to the seabed).
  static double trueRange(const Eigen::Isometry3d& T_w_b, const Eigen::Isometry3d& T_b_s);
  /// Slant range along the beam to the first crossing with the terrain's surface, rocks
  /// included (+inf when the beam meets nothing within max_range).
  static double trueRange(const Eigen::Isometry3d& T_w_b, const Eigen::Isometry3d& T_b_s, const SeabedTerrain& terrain,
                          double max_range);

  SonarReading measure(const Eigen::Isometry3d& T_w_b);

  const SonarParams& params() const { return params_; }

 private:
  SonarParams params_;
  Eigen::Isometry3d T_b_s_;
  Rng rng_;
  std::shared_ptr<const SeabedTerrain> terrain_;  ///< null when flat
};

// ---------------------------------------------------------------------------------------------
// Pressure (depth) sensor
// ---------------------------------------------------------------------------------------------

/// The water above the vehicle: what turns the port's height into an absolute pressure.
struct WaterColumn {
  double surface_z = 10.0;           ///< water surface height in world ENU [m]
  double atmospheric_pa = 101325.0;  ///< true air pressure on the surface [Pa]
  double density = 1025.0;           ///< [kg/m^3]
  double gravity = 9.81;             ///< [m/s^2]

  /// Hydrostatic absolute pressure at world height z [Pa].
  double pressureAt(double z) const { return atmospheric_pa + density * gravity * (surface_z - z); }
};

struct PressureParams {
  double rate_hz = 10.0;
  /// White noise [Pa]: 80 Pa is 0.8 cm of water, a good AUV depth sensor (0.01 % of a 100 bar
  /// range) sampled at 10 Hz.
  double noise_std_pa = 80.0;
  double spike_fraction = 0.0;  ///< bad-input testing: this fraction of samples carries a spike
  double spike_min_pa = 1.5e4;  ///< spike magnitude U(min, max), random sign (1.5-2.5 m of water)
  double spike_max_pa = 2.5e4;
};

struct PressureReading {
  double pressure = 0.0;       ///< measured absolute pressure [Pa]
  double true_pressure = 0.0;  ///< noise-free [Pa]
  bool spike = false;
};

class PressureSimulator {
 public:
  PressureSimulator(const PressureParams& params, const Eigen::Isometry3d& T_b_p, const WaterColumn& water,
                    uint64_t seed);

  /// Noise-free absolute pressure at the port T_w_b * T_b_p (only its height matters).
  static double truePressure(const Eigen::Isometry3d& T_w_b, const Eigen::Isometry3d& T_b_p, const WaterColumn& water);

  PressureReading measure(const Eigen::Isometry3d& T_w_b);

  const PressureParams& params() const { return params_; }

 private:
  PressureParams params_;
  Eigen::Isometry3d T_b_p_;
  WaterColumn water_;
  Rng rng_;
};

// ---------------------------------------------------------------------------------------------
// Magnetometer
// ---------------------------------------------------------------------------------------------

struct MagnetometerParams {
  double rate_hz = 1000.0;
  double noise_std = 5.0e-9;  ///< [T] white noise per sample and axis
};

class MagnetometerSimulator {
 public:
  MagnetometerSimulator(const MagnetometerParams& params, const Eigen::Isometry3d& T_b_m, MagneticWorld world,
                        uint64_t seed);

  /// Noise-free field in the mag frame [T] at time t (seconds from the sequence start).
  static Eigen::Vector3d trueField(const Eigen::Isometry3d& T_w_b, const Eigen::Isometry3d& T_b_m,
                                   const MagneticWorld& world, double t);

  /// True field (through the vehicle's iron, when set) plus white noise.
  Eigen::Vector3d measure(const Eigen::Isometry3d& T_w_b, double t);
  /// The vehicle's iron (vims_sim --mag-hard-iron-ut, --mag-soft-iron-pct): an uncalibrated magnetometer.
  void setIron(const MagnetometerIron& iron) { iron_ = iron; }

  /// The vehicle's own thrusters (vims_sim --thrusters): their field in the mag frame [T] for the
  /// state at the next sample (call in time order: the lines' phases integrate their frequency).
  void setThrusters(const ThrusterInterference& thrusters) { thrusters_ = thrusters; }
  bool hasThrusters() const { return thrusters_.has_value(); }
  Eigen::Vector3d thrusterField(const TrajectoryState& state);

  const MagnetometerParams& params() const { return params_; }

 private:
  MagnetometerParams params_;
  Eigen::Isometry3d T_b_m_;
  MagneticWorld world_;
  Rng rng_;
  std::optional<ThrusterInterference> thrusters_;
  std::optional<MagnetometerIron> iron_;
  std::array<double, 2> line_phase_{0.0, 0.0};
  double last_thruster_t_ = 0.0;
  bool have_thruster_t_ = false;
};

}  // namespace sim
}  // namespace vims
