#pragma once
/// @file magnetic_field.h
/// @brief Magnetic field models: the seabed coil (an alternating magnetic dipole), the site's
/// geomagnetic field, and the magnetometer that measures their sum.

#include <Eigen/Core>

namespace vims {
namespace sim {

/// Vacuum permeability [T m / A] (seawater is non-magnetic, mu_r = 1).
constexpr double kMu0 = 4.0e-7 * M_PI;

/// A circular coil lying on the seabed with a vertical axis, driven by a sinusoidal current
/// I(t) = current * sin(2 pi frequency t + phase). Far from the coil (a few diameters) it is a
/// magnetic dipole with moment m(t) = turns * I(t) * area along +z (world up).
struct CoilDipole {
  Eigen::Vector3d position_w = Eigen::Vector3d::Zero();  ///< coil centre in world ENU [m]
  int turns = 330;
  double current = 2.9;     ///< peak current [A]
  double diameter = 0.6;    ///< [m]
  double frequency = 11.0;  ///< [Hz]
  double phase = 0.0;       ///< [rad] at t = 0 (the sequence start)

  /// Peak magnetic moment vector [A m^2] (vertical axis: only z is non-zero).
  Eigen::Vector3d peakMoment() const;

  /// Peak amplitude vector of the alternating field at `p_w` [T] in world ENU: the analytic
  /// dipole field B = mu0 / (4 pi r^3) [3 r_hat (m . r_hat) - m] for the peak moment m.
  /// The instantaneous field is this vector times sin(2 pi f t + phase). Returns zero at the
  /// centre itself (the dipole model is singular there).
  Eigen::Vector3d peakField(const Eigen::Vector3d& p_w) const;

  /// Instantaneous field [T] at `p_w` and time t (seconds from the sequence start).
  Eigen::Vector3d field(const Eigen::Vector3d& p_w, double t) const;

  /// sin(2 pi f t + phase): the factor between peakField() and field().
  double waveform(double t) const;
};

/// A constant geomagnetic field, given the way geophysicists do: total intensity F,
/// inclination I (positive: the field points down, northern hemisphere) and declination D
/// (angle from geographic north to magnetic north, east positive).
struct GeomagneticField {
  double total = 49.0e-6;         ///< F [T]
  double inclination_deg = 46.0;  ///< I [deg]
  double declination_deg = 0.0;   ///< D [deg]

  /// Field vector in world ENU [T]: (H sin D, H cos D, -F sin I) with H = F cos I.
  Eigen::Vector3d fieldEnu() const;
};

}  // namespace sim
}  // namespace vims
