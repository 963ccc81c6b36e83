#pragma once
/// @file magnetic_field.h
/// @brief Magnetic field models: the seabed coils (alternating magnetic dipoles), the site's
/// geomagnetic field, a local magnetic anomaly (buried ferrous material), and the magnetometer
/// that measures their sum.

#include <Eigen/Core>
#include <optional>
#include <vector>

namespace vims {
namespace sim {

/// Vacuum permeability [T m / A] (seawater is non-magnetic, mu_r = 1).
constexpr double kMu0 = 4.0e-7 * M_PI;

/// The field of a point magnetic dipole of moment m [A m^2] at offset r [m] from it [T]:
/// B = mu0 / (4 pi |r|^3) [3 r_hat (m . r_hat) - m]. Zero at r = 0 (singular there).
Eigen::Vector3d dipoleField(const Eigen::Vector3d& moment, const Eigen::Vector3d& r);

/// A circular coil lying on the seabed with a vertical axis, driven by a sinusoidal current
/// I(t) = current * sin(2 pi (frequency t + frequency_rate t^2 / 2) + phase): a free-running
/// oscillator whose frequency frequency + frequency_rate t drifts slowly (temperature, battery).
/// Far from the coil (a few diameters) it is a magnetic dipole with moment
/// m(t) = turns * I(t) * area along +z (world up).
struct CoilDipole {
  Eigen::Vector3d position_w = Eigen::Vector3d::Zero();  ///< coil centre in world ENU [m]
  int turns = 330;
  double current = 2.9;         ///< peak current [A]
  double diameter = 0.6;        ///< [m]
  double frequency = 11.0;      ///< [Hz] at t = 0
  double frequency_rate = 0.0;  ///< [Hz/s] linear drift of the frequency
  double phase = 0.0;           ///< [rad] at t = 0 (the sequence start)

  /// Peak magnetic moment vector [A m^2] (vertical axis: only z is non-zero).
  Eigen::Vector3d peakMoment() const;

  /// Peak amplitude vector of the alternating field at `p_w` [T] in world ENU: the analytic
  /// dipole field B = mu0 / (4 pi r^3) [3 r_hat (m . r_hat) - m] for the peak moment m.
  /// The instantaneous field is this vector times sin(2 pi f t + phase). Returns zero at the
  /// centre itself (the dipole model is singular there).
  Eigen::Vector3d peakField(const Eigen::Vector3d& p_w) const;

  /// Instantaneous field [T] at `p_w` and time t (seconds from the sequence start).
  Eigen::Vector3d field(const Eigen::Vector3d& p_w, double t) const;

  /// sin(2 pi (f t + rate t^2 / 2) + phase): the factor between peakField() and field().
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

/// A static local disturbance of the geomagnetic field: ferrous material buried in the seabed
/// (a wreck, a pipe, magnetite-bearing rock). Steel far from saturation carries an induced
/// magnetisation along the ambient field, so it is a point dipole whose moment points along the
/// site's geomagnetic field; its field falls off as 1/r^3 and is constant in time, so the
/// magnetometer's low-pass keeps it and the geomagnetic heading bends near it.
struct MagneticAnomaly {
  Eigen::Vector3d position_w = Eigen::Vector3d::Zero();  ///< dipole in world ENU [m] (below the seabed)
  Eigen::Vector3d moment_enu = Eigen::Vector3d::Zero();  ///< [A m^2]

  /// Field [T] at `p_w` in world ENU.
  Eigen::Vector3d field(const Eigen::Vector3d& p_w) const { return dipoleField(moment_enu, p_w - position_w); }

  /// The anomaly that reaches `peak_tesla` at `above_w` (the vehicle's height straight above the
  /// dipole), buried `depth_m` below that point, magnetised along `geomagnetic_enu`.
  static MagneticAnomaly induced(const Eigen::Vector3d& above_w, double depth_m, double peak_tesla,
                                 const Eigen::Vector3d& geomagnetic_enu);
};

/// Everything magnetic at the site; the magnetometer measures the sum.
struct MagneticWorld {
  Eigen::Vector3d geomagnetic_enu = Eigen::Vector3d::Zero();  ///< [T]
  CoilDipole coil;                                            ///< the first (or only) coil
  std::optional<MagneticAnomaly> anomaly;
  /// The further coils of a site with several (vims_sim --coil-frequencies), in the sequence's
  /// order: coil i of the sequence's coil_frequency_hz list is other_coils[i - 1].
  std::vector<CoilDipole> other_coils;

  /// Field [T] in world ENU at `p_w` and time t (seconds from the sequence start): the
  /// geomagnetic field, every coil's alternating field and the anomaly's.
  Eigen::Vector3d fieldEnu(const Eigen::Vector3d& p_w, double t) const {
    Eigen::Vector3d field = geomagnetic_enu + coil.field(p_w, t);
    for (const CoilDipole& other : other_coils) field += other.field(p_w, t);
    if (anomaly) field += anomaly->field(p_w);
    return field;
  }
};

}  // namespace sim
}  // namespace vims
