#include "vims_sim/sensor_models.h"

#include <cmath>
#include <limits>

namespace vims {
namespace sim {

ImuNoiseParams ImuNoiseParams::mti630() {
  constexpr double kDeg = M_PI / 180.0;
  constexpr double kMicroG = 9.81e-6;
  // In-run bias stability B reached at Allan time tau by a rate random walk K: B = K sqrt(tau/3).
  constexpr double kAllanTime = 300.0;
  const double random_walk_factor = std::sqrt(3.0 / kAllanTime);
  ImuNoiseParams p;
  p.rate_hz = 200.0;
  p.gyro_noise_density = 0.007 * kDeg;                            // 1.22e-4 rad/s/sqrt(Hz)
  p.gyro_random_walk = 8.0 * kDeg / 3600.0 * random_walk_factor;  // 3.9e-6 rad/s^2/sqrt(Hz)
  p.accel_noise_density = 60.0 * kMicroG;                         // 5.9e-4 m/s^2/sqrt(Hz)
  p.accel_random_walk = 10.0 * kMicroG * random_walk_factor;      // 9.8e-6 m/s^3/sqrt(Hz)
  p.gravity = 9.81;
  p.gyro_initial_bias_std = 0.05 * kDeg;
  p.accel_initial_bias_std = 1.5e3 * kMicroG;
  return p;
}

ImuSimulator::ImuSimulator(const ImuNoiseParams& params, const Eigen::Vector3d& gyro_bias,
                           const Eigen::Vector3d& accel_bias, uint64_t seed)
    : params_(params), gyro_bias_(gyro_bias), accel_bias_(accel_bias), rng_(seed) {}

Eigen::Vector3d ImuSimulator::idealSpecificForce(const TrajectoryState& state, double gravity) {
  const Eigen::Vector3d g_w(0.0, 0.0, -gravity);
  return state.q_w_b.conjugate() * (state.a_w_b - g_w);
}

ImuMeasurement ImuSimulator::measure(const TrajectoryState& state) {
  const double sqrt_rate = std::sqrt(params_.rate_hz);
  const double gyro_std = params_.gyro_noise_density * sqrt_rate;
  const double accel_std = params_.accel_noise_density * sqrt_rate;
  ImuMeasurement m;
  m.gyro_bias = gyro_bias_;
  m.accel_bias = accel_bias_;
  const Eigen::Vector3d gyro_noise(rng_.gaussian(gyro_std), rng_.gaussian(gyro_std), rng_.gaussian(gyro_std));
  const Eigen::Vector3d accel_noise(rng_.gaussian(accel_std), rng_.gaussian(accel_std), rng_.gaussian(accel_std));
  m.gyro = state.omega_b + gyro_bias_ + gyro_noise;
  m.accel = idealSpecificForce(state, params_.gravity) + accel_bias_ + accel_noise;
  const double gyro_walk = params_.gyro_random_walk / sqrt_rate;
  const double accel_walk = params_.accel_random_walk / sqrt_rate;
  for (int i = 0; i < 3; ++i) gyro_bias_[i] += rng_.gaussian(gyro_walk);
  for (int i = 0; i < 3; ++i) accel_bias_[i] += rng_.gaussian(accel_walk);
  return m;
}

SonarSimulator::SonarSimulator(const SonarParams& params, const Eigen::Isometry3d& T_b_s, uint64_t seed,
                               std::shared_ptr<const SeabedTerrain> terrain)
    : params_(params), T_b_s_(T_b_s), rng_(seed), terrain_(terrain && !terrain->isFlat() ? terrain : nullptr) {}

double SonarSimulator::trueRange(const Eigen::Isometry3d& T_w_b, const Eigen::Isometry3d& T_b_s) {
  const Eigen::Isometry3d T_w_s = T_w_b * T_b_s;
  const Eigen::Vector3d beam_w = T_w_s.linear().col(2);
  const double height = T_w_s.translation().z();
  if (beam_w.z() > -1e-9 || height <= 0.0) return std::numeric_limits<double>::infinity();
  return -height / beam_w.z();
}

double SonarSimulator::trueRange(const Eigen::Isometry3d& T_w_b, const Eigen::Isometry3d& T_b_s,
                                 const SeabedTerrain& terrain, double max_range) {
  const Eigen::Isometry3d T_w_s = T_w_b * T_b_s;
  const Eigen::Vector3d beam_w = T_w_s.linear().col(2);  // unit: the ray parameter is the range
  TerrainHit hit;
  if (!terrain.intersectRay(T_w_s.translation(), beam_w, max_range, &hit)) {
    return std::numeric_limits<double>::infinity();
  }
  return hit.t;
}

SonarReading SonarSimulator::measure(const Eigen::Isometry3d& T_w_b) {
  // Always draw the same number of random numbers per ping so the stream stays aligned.
  const double u_dropout = rng_.uniform();
  const double u_outlier = rng_.uniform();
  const double factor = rng_.uniform(params_.outlier_min_factor, params_.outlier_max_factor);
  const double noise = rng_.gaussian(params_.range_noise_std);

  SonarReading reading;
  reading.true_range = terrain_ ? trueRange(T_w_b, T_b_s_, *terrain_, params_.max_range) : trueRange(T_w_b, T_b_s_);
  if (!std::isfinite(reading.true_range) || reading.true_range > params_.max_range) {
    reading.kind = SonarReading::Kind::kOutOfRange;
    reading.range = std::numeric_limits<double>::infinity();
  } else if (u_dropout < params_.dropout_probability) {
    reading.kind = SonarReading::Kind::kDropout;
    reading.range = std::numeric_limits<double>::infinity();
  } else if (u_outlier < params_.outlier_probability) {
    reading.kind = SonarReading::Kind::kOutlier;
    reading.range = reading.true_range * factor + noise;
  } else {
    reading.kind = SonarReading::Kind::kGood;
    reading.range = std::max(params_.min_range, reading.true_range + noise);
  }
  return reading;
}

PressureSimulator::PressureSimulator(const PressureParams& params, const Eigen::Isometry3d& T_b_p,
                                     const WaterColumn& water, uint64_t seed)
    : params_(params), T_b_p_(T_b_p), water_(water), rng_(seed) {}

double PressureSimulator::truePressure(const Eigen::Isometry3d& T_w_b, const Eigen::Isometry3d& T_b_p,
                                       const WaterColumn& water) {
  return water.pressureAt((T_w_b * T_b_p.translation()).z());
}

PressureReading PressureSimulator::measure(const Eigen::Isometry3d& T_w_b) {
  // Always the same random numbers per sample, so the stream stays aligned.
  const double noise = rng_.gaussian(params_.noise_std_pa);
  const double u_spike = rng_.uniform();
  const double spike = rng_.sign() * rng_.uniform(params_.spike_min_pa, params_.spike_max_pa);
  PressureReading reading;
  reading.true_pressure = truePressure(T_w_b, T_b_p_, water_);
  reading.spike = u_spike < params_.spike_fraction;
  reading.pressure = reading.true_pressure + noise + (reading.spike ? spike : 0.0);
  return reading;
}

MagnetometerSimulator::MagnetometerSimulator(const MagnetometerParams& params, const Eigen::Isometry3d& T_b_m,
                                             MagneticWorld world, uint64_t seed)
    : params_(params), T_b_m_(T_b_m), world_(std::move(world)), rng_(seed) {}

Eigen::Vector3d MagnetometerSimulator::trueField(const Eigen::Isometry3d& T_w_b, const Eigen::Isometry3d& T_b_m,
                                                 const MagneticWorld& world, double t) {
  const Eigen::Isometry3d T_w_m = T_w_b * T_b_m;
  return T_w_m.linear().transpose() * world.fieldEnu(T_w_m.translation(), t);
}

Eigen::Vector3d MagnetometerSimulator::thrusterField(const TrajectoryState& state) {
  const ThrusterInterference& th = *thrusters_;
  const double u = th.relativeThrust(state);
  const double dt = have_thruster_t_ ? state.t - last_thruster_t_ : 0.0;
  have_thruster_t_ = true;
  last_thruster_t_ = state.t;
  Eigen::Vector3d field = Eigen::Vector3d::Zero();
  for (int i = 0; i < 2; ++i) {
    line_phase_[i] = std::fmod(line_phase_[i] + 2.0 * M_PI * th.lineFrequency(i, u) * dt, 2.0 * M_PI);
    field += th.line_direction_m[i] * (th.line_amplitude_tesla * u * std::sin(line_phase_[i]));
  }
  field += th.hard_iron_direction_m * (th.hard_iron_tesla * u);
  const double s = th.broadband_std_tesla * u;
  field += Eigen::Vector3d(rng_.gaussian(s), rng_.gaussian(s), rng_.gaussian(s));
  return field;
}

Eigen::Vector3d MagnetometerSimulator::measure(const Eigen::Isometry3d& T_w_b, double t) {
  const double s = params_.noise_std;
  const Eigen::Vector3d noise(rng_.gaussian(s), rng_.gaussian(s), rng_.gaussian(s));
  const Eigen::Vector3d field = trueField(T_w_b, T_b_m_, world_, t);
  return (iron_ ? iron_->apply(field) : field) + noise;
}

}  // namespace sim
}  // namespace vims
