#pragma once
/// @file thruster_interference.h
/// @brief The magnetic signature of the vehicle's two stern thrusters at its magnetometer: lines
/// at the motors' electrical frequency, a hard-iron offset and broadband noise, all following the
/// thrust (vims_sim --thrusters).
///
/// Physics, per thruster: the propeller's thrust goes as RPM^2, so the motor's electrical
/// frequency (pole pairs x RPM) goes as sqrt(thrust); the motor current, which makes the static
/// offset, the line and the switching noise, goes as its torque, ~RPM^2 ~ thrust. The thrust
/// balances the hull's drag (~ v|v| along the body's forward axis) plus the vehicle's inertia
/// (m a), so the thrusters' lines sweep with the speed and spike as the vehicle accelerates.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>

namespace vims {
namespace sim {

struct TrajectoryState;

struct ThrusterInterference {
  /// Forward speed at which each thruster gives its reference thrust [m/s].
  double reference_speed_mps = 0.5;
  /// Vehicle mass (with added mass) over the hull's 1/2 rho Cd A [m]: the inertia term's weight
  /// against the drag (40 kg / (0.5 * 1025 * 0.8 * 0.03 m^2) ~ 3.3 m for a 1.5 m AUV).
  double inertia_length_m = 3.3;
  /// Electrical line frequency of thruster 0 at the reference thrust [Hz]; thruster 1 runs
  /// `second_motor_ratio` times faster (two motors never match).
  double line_frequency_hz = 45.0;
  double second_motor_ratio = 1.04;
  double line_amplitude_tesla = 200e-9;  ///< peak line amplitude at the reference thrust
  double hard_iron_tesla = 3e-6;         ///< static offset at the reference thrust
  double broadband_std_tesla = 15e-9;    ///< extra white noise per axis at the reference thrust
  std::array<Eigen::Vector3d, 2> line_direction_m{Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY()};
  Eigen::Vector3d hard_iron_direction_m = Eigen::Vector3d::UnitZ();  ///< unit, mag frame

  /// Thrust of each thruster relative to the reference (>= 0) for the vehicle's state (both push
  /// alike; only their motors' frequencies differ).
  double relativeThrust(const TrajectoryState& state) const;
  /// Electrical frequency of thruster i at relative thrust u [Hz].
  double lineFrequency(int i, double u) const;
};

/// Seeded directions for the lines and the offset (the motors' placement relative to the
/// magnetometer), the rest as given.
ThrusterInterference seededThrusterInterference(const ThrusterInterference& params, uint64_t seed);

/// The vehicle's iron as a magnetometer that was not calibrated sees it (vims_sim
/// --mag-hard-iron-ut, --mag-soft-iron-pct): m = soft_iron h + hard_iron_t for the outside field h
/// (the geomagnetic field, the coils, an anomaly). The thrusters' own field is added after it.
struct MagnetometerIron {
  Eigen::Vector3d hard_iron_t = Eigen::Vector3d::Zero();    ///< [T], mag frame
  Eigen::Matrix3d soft_iron = Eigen::Matrix3d::Identity();  ///< symmetric, near I
  Eigen::Vector3d apply(const Eigen::Vector3d& h) const { return soft_iron * h + hard_iron_t; }
};

/// A hard iron of `hard_iron_ut` [uT] in a seeded direction, and a soft iron whose gains along
/// three seeded orthogonal axes are 1 + pct/100, 1 - pct/100 and 1 + u pct/100 (u uniform in
/// [-1, 1]): induced magnetisation scales and skews the field by up to pct percent.
MagnetometerIron seededMagnetometerIron(double hard_iron_ut, double soft_iron_pct, uint64_t seed);

}  // namespace sim
}  // namespace vims
