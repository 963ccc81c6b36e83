#include "vims_sim/thruster_interference.h"

#include <algorithm>
#include <cmath>

#include "vims_sim/random.h"
#include "vims_sim/trajectory.h"

namespace vims {
namespace sim {

double ThrusterInterference::relativeThrust(const TrajectoryState& state) const {
  const Eigen::Matrix3d R_b_w = state.q_w_b.toRotationMatrix().transpose();
  const double v = (R_b_w * state.v_w_b).x();  // body FLU: x forward
  const double a = (R_b_w * state.a_w_b).x();
  // Thrust / (1/2 rho Cd A) = v|v| + (m / (1/2 rho Cd A)) a; thrusters push, never pull here.
  return std::max(0.0, (v * std::abs(v) + inertia_length_m * a) / (reference_speed_mps * reference_speed_mps));
}

double ThrusterInterference::lineFrequency(int i, double u) const {
  return line_frequency_hz * std::sqrt(std::max(0.0, u)) * (i == 0 ? 1.0 : second_motor_ratio);
}

namespace {
Eigen::Vector3d randomUnit(Rng& rng) {
  Eigen::Vector3d d(rng.gaussian(), rng.gaussian(), rng.gaussian());
  return d.norm() > 1e-9 ? Eigen::Vector3d(d.normalized()) : Eigen::Vector3d::UnitX();
}
}  // namespace

ThrusterInterference seededThrusterInterference(const ThrusterInterference& params, uint64_t seed) {
  ThrusterInterference t = params;
  Rng rng(seed);
  t.line_direction_m[0] = randomUnit(rng);
  t.line_direction_m[1] = randomUnit(rng);
  t.hard_iron_direction_m = randomUnit(rng);
  return t;
}

MagnetometerIron seededMagnetometerIron(double hard_iron_ut, double soft_iron_pct, uint64_t seed) {
  Rng rng(seed);
  MagnetometerIron iron;
  iron.hard_iron_t = randomUnit(rng) * (hard_iron_ut * 1e-6);
  const Eigen::Quaterniond axes =
      Eigen::Quaterniond(rng.gaussian(), rng.gaussian(), rng.gaussian(), rng.gaussian()).normalized();
  const double p = soft_iron_pct / 100.0;
  const Eigen::Vector3d gains(1.0 + p, 1.0 - p, 1.0 + rng.uniform(-1.0, 1.0) * p);
  const Eigen::Matrix3d Q = axes.toRotationMatrix();
  iron.soft_iron = Q * gains.asDiagonal() * Q.transpose();
  return iron;
}

}  // namespace sim
}  // namespace vims
