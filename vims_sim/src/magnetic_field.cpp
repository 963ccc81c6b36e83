#include "vims_sim/magnetic_field.h"

#include <cmath>

namespace vims {
namespace sim {

Eigen::Vector3d dipoleField(const Eigen::Vector3d& moment, const Eigen::Vector3d& r) {
  const double distance = r.norm();
  if (distance < 1e-9) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d r_hat = r / distance;
  return kMu0 / (4.0 * M_PI * distance * distance * distance) * (3.0 * r_hat * moment.dot(r_hat) - moment);
}

Eigen::Vector3d CoilDipole::peakMoment() const {
  const double area = M_PI * 0.25 * diameter * diameter;
  return Eigen::Vector3d(0.0, 0.0, static_cast<double>(turns) * current * area);
}

Eigen::Vector3d CoilDipole::peakField(const Eigen::Vector3d& p_w) const {
  return dipoleField(peakMoment(), p_w - position_w);
}

double CoilDipole::waveform(double t) const {
  // The phase is the integral of the instantaneous frequency.
  return std::sin(2.0 * M_PI * (frequency + 0.5 * frequency_rate * t) * t + phase);
}

Eigen::Vector3d CoilDipole::field(const Eigen::Vector3d& p_w, double t) const { return peakField(p_w) * waveform(t); }

Eigen::Vector3d GeomagneticField::fieldEnu() const {
  const double inclination = inclination_deg * M_PI / 180.0;
  const double declination = declination_deg * M_PI / 180.0;
  const double horizontal = total * std::cos(inclination);
  return Eigen::Vector3d(horizontal * std::sin(declination), horizontal * std::cos(declination),
                         -total * std::sin(inclination));
}

MagneticAnomaly MagneticAnomaly::induced(const Eigen::Vector3d& above_w, double depth_m, double peak_tesla,
                                         const Eigen::Vector3d& geomagnetic_enu) {
  MagneticAnomaly a;
  a.position_w = above_w - Eigen::Vector3d(0.0, 0.0, depth_m);
  // The field is linear in the moment: scale a unit moment along the ambient field.
  const Eigen::Vector3d direction = geomagnetic_enu.normalized();
  const double unit_peak = dipoleField(direction, above_w - a.position_w).norm();
  a.moment_enu = direction * (peak_tesla / unit_peak);
  return a;
}

}  // namespace sim
}  // namespace vims
