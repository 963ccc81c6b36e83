#pragma once
// A synthetic vehicle for the magnetometer tests: a known trajectory (position and attitude in
// ENU), the IMU it would measure, and a magnetometer measuring the geomagnetic field plus a
// seabed coil's alternating dipole field, with noise. Written independently of vims_sim so the
// cores are tested against a model they do not share code with.
#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "vims_common/magnetic_signature.h"
#include "vims_common/sensor_data.h"

namespace vims_test {

struct Motion {
  std::function<Eigen::Vector3d(double)> p_w_b;     // position [m]
  std::function<Eigen::Quaterniond(double)> q_w_b;  // attitude
};

/// A circle of radius r around `centre` at speed v, heading along the path, with small roll and
/// pitch oscillations.
inline Motion circle(const Eigen::Vector3d& centre, double r, double v, double roll_deg = 2.0, double pitch_deg = 3.0) {
  Motion m;
  const double w = v / r;
  m.p_w_b = [=](double t) {
    return Eigen::Vector3d(centre + r * Eigen::Vector3d(std::cos(w * t), std::sin(w * t), 0));
  };
  m.q_w_b = [=](double t) {
    const double yaw = w * t + M_PI / 2;
    const double pitch = pitch_deg * M_PI / 180 * std::sin(0.5 * t);
    const double roll = roll_deg * M_PI / 180 * std::sin(0.3 * t);
    return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
  };
  return m;
}

/// Standing at p, turning in place at yaw_rate from yaw0.
inline Motion turnInPlace(const Eigen::Vector3d& p, double yaw0, double yaw_rate) {
  Motion m;
  m.p_w_b = [=](double) { return p; };
  m.q_w_b = [=](double t) {
    return Eigen::Quaterniond(Eigen::AngleAxisd(yaw0 + yaw_rate * t, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(0.03 * std::sin(0.7 * t), Eigen::Vector3d::UnitY()));
  };
  return m;
}

struct World {
  Eigen::Vector3d coil_w{0.0, 0.0, 0.0};
  double coil_moment = 270.0;        // peak dipole moment along +z [A m^2]
  double coil_frequency = 11.0;      // [Hz]
  double coil_phase = 0.4;           // [rad]
  double coil_frequency_rate = 0.0;  // [Hz/s] a drifting coil: f(tau) = coil_frequency + rate tau
  double declination_deg = 5.0;
  double inclination_deg = 46.0;
  double total_field = 49e-6;  // [T]
  double gravity = 9.81;

  Eigen::Vector3d geomagneticEnu() const {
    const double D = declination_deg * M_PI / 180, I = inclination_deg * M_PI / 180;
    const double H = total_field * std::cos(I);
    return {H * std::sin(D), H * std::cos(D), -total_field * std::sin(I)};
  }
  /// Peak dipole field at p (mu0/4pi = 1e-7).
  Eigen::Vector3d coilPeak(const Eigen::Vector3d& p_w) const {
    const Eigen::Vector3d r = p_w - coil_w;
    const double d = r.norm();
    const Eigen::Vector3d rh = r / d;
    const Eigen::Vector3d m(0, 0, coil_moment);
    return 1e-7 / (d * d * d) * (3.0 * rh * m.dot(rh) - m);
  }
};

struct Streams {
  std::vector<vims::ImuSample> imu;
  std::vector<vims::MagSample> mag;
};

/// IMU at 200 Hz and magnetometer at 1000 Hz from t0 to t0 + duration. T_b_m rotates the mag frame.
inline Streams generate(const Motion& motion, const World& world, double t0, double duration,
                        const Eigen::Matrix3d& R_b_m, double mag_noise, double gyro_bias = 0.0, unsigned seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  Streams s;
  const double h = 1e-3;
  for (int k = 0; k <= static_cast<int>(duration * 200); ++k) {
    const double tau = k / 200.0;
    const Eigen::Quaterniond q0 = motion.q_w_b(tau - h), q1 = motion.q_w_b(tau + h);
    const Eigen::AngleAxisd delta(q0.conjugate() * q1);
    vims::ImuSample imu;
    imu.t = t0 + tau;
    imu.gyro = delta.axis() * delta.angle() / (2 * h) + Eigen::Vector3d::Constant(gyro_bias) +
               Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 1e-3;
    const Eigen::Vector3d a_w = (motion.p_w_b(tau + h) - 2 * motion.p_w_b(tau) + motion.p_w_b(tau - h)) / (h * h);
    imu.accel = motion.q_w_b(tau).conjugate() * (a_w + Eigen::Vector3d(0, 0, world.gravity)) +
                Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 0.02;
    s.imu.push_back(imu);
  }
  const Eigen::Vector3d B_e = world.geomagneticEnu();
  for (int k = 0; k <= static_cast<int>(duration * 1000); ++k) {
    const double tau = k / 1000.0;
    const Eigen::Matrix3d R_w_b = motion.q_w_b(tau).toRotationMatrix();
    const Eigen::Vector3d B_w =
        B_e + world.coilPeak(motion.p_w_b(tau)) *
                  std::sin(2 * M_PI * (world.coil_frequency + 0.5 * world.coil_frequency_rate * tau) * tau +
                           world.coil_phase);
    vims::MagSample mag;
    mag.t = t0 + tau;
    mag.field =
        R_b_m.transpose() * R_w_b.transpose() * B_w + Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * mag_noise;
    s.mag.push_back(mag);
  }
  return s;
}

/// Feeds both streams in time order (IMU first on equal stamps) to the callbacks.
template <typename ImuFn, typename MagFn>
void replay(const Streams& s, ImuFn on_imu, MagFn on_mag) {
  std::size_t i = 0, m = 0;
  while (i < s.imu.size() || m < s.mag.size()) {
    if (m >= s.mag.size() || (i < s.imu.size() && s.imu[i].t <= s.mag[m].t)) {
      on_imu(s.imu[i++]);
    } else {
      on_mag(s.mag[m++]);
    }
  }
}

/// What a magnetometer front end (SignatureExtractor or MagneticFrontEnd) outputs for a stream.
struct Outputs {
  std::vector<vims::SignatureWindow> signatures;
  std::vector<vims::GeomagneticSample> geomagnetic;
};

template <typename FrontEnd>
Outputs run(FrontEnd& front_end, const Streams& streams) {
  Outputs out;
  replay(
      streams, [&](const vims::ImuSample& s) { front_end.feedImu(s); },
      [&](const vims::MagSample& s) { front_end.feedMag(s, &out.signatures, &out.geomagnetic); });
  return out;
}

}  // namespace vims_test
