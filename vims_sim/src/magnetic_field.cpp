#include "vims_sim/magnetic_field.h"

#include <cmath>

namespace vims {
namespace sim {

Eigen::Vector3d CoilDipole::peakMoment() const {
  const double area = M_PI * 0.25 * diameter * diameter;
  return Eigen::Vector3d(0.0, 0.0, static_cast<double>(turns) * current * area);
}

Eigen::Vector3d CoilDipole::peakField(const Eigen::Vector3d& p_w) const {
  const Eigen::Vector3d r = p_w - position_w;
  const double distance = r.norm();
  if (distance < 1e-9) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d r_hat = r / distance;
  const Eigen::Vector3d m = peakMoment();
  return kMu0 / (4.0 * M_PI * distance * distance * distance) * (3.0 * r_hat * m.dot(r_hat) - m);
}

double CoilDipole::waveform(double t) const { return std::sin(2.0 * M_PI * frequency * t + phase); }

Eigen::Vector3d CoilDipole::field(const Eigen::Vector3d& p_w, double t) const { return peakField(p_w) * waveform(t); }

Eigen::Vector3d GeomagneticField::fieldEnu() const {
  const double inclination = inclination_deg * M_PI / 180.0;
  const double declination = declination_deg * M_PI / 180.0;
  const double horizontal = total * std::cos(inclination);
  return Eigen::Vector3d(horizontal * std::sin(declination), horizontal * std::cos(declination),
                         -total * std::sin(inclination));
}

}  // namespace sim
}  // namespace vims
