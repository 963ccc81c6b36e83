#include "vims_magnetometer/attitude_filter.h"

#include <algorithm>
#include <cmath>

namespace vims {
namespace {
constexpr const char* kComponent = "attitude_filter";
/// Half-width [s] of the interval whose specific force is averaged for initialisation: long
/// enough to average accelerometer noise, short against attitude changes of a slow AUV.
constexpr double kInitAverageHalfWidth = 0.25;
/// Below this ratio of horizontal to total field the azimuth is meaningless (near a magnetic
/// pole, or a field disturbed by the vehicle) and the heading correction is skipped.
constexpr double kMinHorizontalFieldRatio = 0.1;
/// No real gyro has a bias near 0.1 rad/s (6 deg/s); the estimate is clamped there so that a
/// long disturbance (e.g. a magnet near the sensor) cannot wind the integrator up without bound.
constexpr double kMaxGyroBias = 0.1;
/// A geomagnetic value older than this [s] (e.g. during a magnetometer gap) no longer steers the heading.
constexpr double kMaxGeomagneticAge = 1.0;

Eigen::Quaterniond expMap(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < 1e-12) return Eigen::Quaterniond(1.0, 0.5 * phi.x(), 0.5 * phi.y(), 0.5 * phi.z()).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, phi / angle));
}

double wrapPi(double a) { return std::atan2(std::sin(a), std::cos(a)); }
}  // namespace

AttitudeFilter::AttitudeFilter(const AttitudeFilterOptions& options, double gravity, double declination_rad,
                               double history_s, LoggerPtr logger)
    : options_(options),
      gravity_(gravity),
      declination_rad_(declination_rad),
      history_s_(std::max(history_s, 2.0 * options.max_imu_gap_s)),
      logger_(logger ? std::move(logger) : Logger::nullLogger()) {
  options_.validate(ConfigReader::fromString("", "attitude filter options"));
}

void AttitudeFilter::reset() {
  initialized_ = false;
  q_w_b_ = Eigen::Quaterniond::Identity();
  gyro_bias_.setZero();
  have_last_imu_ = false;
  imu_buffer_.clear();
  history_.clear();
  have_geomagnetic_ = false;
}

std::optional<Eigen::Quaterniond> AttitudeFilter::fromGravityAndField(const Eigen::Vector3d& f_b,
                                                                      const Eigen::Vector3d& B_b,
                                                                      double declination_rad) {
  if (f_b.norm() < 1e-6 || B_b.norm() < 1e-12) return std::nullopt;
  const Eigen::Vector3d up_b = f_b.normalized();
  const Eigen::Vector3d east_cross = B_b.cross(up_b);  // |B_horizontal| * magnetic east
  if (east_cross.norm() < kMinHorizontalFieldRatio * B_b.norm()) return std::nullopt;
  const Eigen::Vector3d east_b = east_cross.normalized();
  const Eigen::Vector3d north_b = up_b.cross(east_b);
  Eigen::Matrix3d R_mag_b;  // rows: magnetic east, magnetic north, up, expressed in the body
  R_mag_b.row(0) = east_b.transpose();
  R_mag_b.row(1) = north_b.transpose();
  R_mag_b.row(2) = up_b.transpose();
  // Magnetic north lies at azimuth D east of true north: true ENU = Rz(-D) * magnetic ENU.
  const Eigen::Matrix3d R_w_b = Eigen::AngleAxisd(-declination_rad, Eigen::Vector3d::UnitZ()) * R_mag_b;
  return Eigen::Quaterniond(R_w_b).normalized();
}

void AttitudeFilter::trim(double t_newest) {
  while (!imu_buffer_.empty() && imu_buffer_.front().t < t_newest - history_s_) imu_buffer_.pop_front();
  while (history_.size() > 2 && history_[1].t < t_newest - history_s_) history_.pop_front();
}

void AttitudeFilter::feedImu(const ImuSample& s) {
  if (!std::isfinite(s.t) || !s.gyro.allFinite() || !s.accel.allFinite()) {
    logger_->warnThrottled(kComponent, "nonfinite", have_last_imu_ ? last_imu_t_ : 0.0, 5.0,
                           "non-finite IMU sample ignored");
    return;
  }
  if (have_last_imu_ && s.t < last_imu_t_) {
    logger_->warn(kComponent,
                  VIMS_STR("IMU clock went backwards by " << (last_imu_t_ - s.t) << " s; resetting the attitude"));
    reset();
  } else if (have_last_imu_ && s.t == last_imu_t_) {
    logger_->warnThrottled(kComponent, "duplicate", s.t, 5.0, "duplicate IMU stamp ignored");
    return;
  }
  if (have_last_imu_ && s.t - last_imu_t_ > options_.max_imu_gap_s) {
    if (initialized_) {
      logger_->warnThrottled(kComponent, "gap", s.t, 5.0,
                             VIMS_STR("IMU gap of " << (s.t - last_imu_t_) << " s; re-initialising the attitude"));
    }
    // Gyro integration cannot bridge the gap; the old samples cannot initialise the new state.
    initialized_ = false;
    imu_buffer_.clear();
    history_.clear();
  }
  have_last_imu_ = true;
  last_imu_t_ = s.t;
  imu_buffer_.push_back(s);
  if (initialized_) {
    propagate(s);
  } else {
    tryInitialize();
  }
  trim(s.t);
}

void AttitudeFilter::feedGeomagnetic(double t, const Eigen::Vector3d& B_b) {
  if (!std::isfinite(t) || !B_b.allFinite()) return;
  have_geomagnetic_ = true;
  geomagnetic_t_ = t;
  geomagnetic_b_ = B_b;
  if (!initialized_) tryInitialize();
}

void AttitudeFilter::tryInitialize() {
  if (!have_geomagnetic_ || imu_buffer_.empty()) return;
  const double t_g = geomagnetic_t_;
  // Need IMU coverage at t_g (buffer starts before it, within a gap) and up to it.
  if (imu_buffer_.front().t > t_g + options_.max_imu_gap_s || imu_buffer_.back().t < t_g) return;
  Eigen::Vector3d f_sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (const ImuSample& s : imu_buffer_) {
    if (std::abs(s.t - t_g) <= kInitAverageHalfWidth) {
      f_sum += s.accel;
      ++n;
    }
  }
  if (n == 0) return;
  const auto q0 = fromGravityAndField(f_sum / n, geomagnetic_b_, declination_rad_);
  if (!q0) {
    logger_->warnThrottled(kComponent, "init", t_g, 5.0,
                           "cannot initialise the attitude: gravity and geomagnetic field are parallel or zero");
    return;
  }
  q_w_b_ = *q0;
  t_state_ = t_g;
  history_.clear();
  history_.push_back({t_g, q_w_b_});
  initialized_ = true;
  ++initializations_;
  for (const ImuSample& s : imu_buffer_) {
    if (s.t > t_g) propagate(s);
  }
  logger_->info(kComponent, VIMS_STR("attitude initialised at t=" << std::fixed << t_g
                                                                  << " from gravity and the "
                                                                     "geomagnetic field"));
}

std::optional<Eigen::Quaterniond> AttitudeFilter::attitudeAt(double t) const {
  if (!initialized_ || history_.empty() || !std::isfinite(t)) return std::nullopt;
  if (t >= history_.back().t) {
    if (t - history_.back().t > options_.max_imu_gap_s) return std::nullopt;
    return history_.back().q_w_b;
  }
  if (t < history_.front().t) return std::nullopt;
  const auto upper =
      std::upper_bound(history_.begin(), history_.end(), t, [](double value, const Entry& e) { return value < e.t; });
  const Entry& b = *upper;
  const Entry& a = *(upper - 1);
  const double alpha = (t - a.t) / (b.t - a.t);
  return a.q_w_b.slerp(alpha, b.q_w_b);
}

void AttitudeFilter::propagate(const ImuSample& s) {
  const double dt = s.t - t_state_;
  if (dt <= 0.0) return;
  q_w_b_ = q_w_b_ * expMap((s.gyro - gyro_bias_) * dt);
  Eigen::Vector3d correction_b = Eigen::Vector3d::Zero();  // applied correction rotation, body frame

  // Tilt: rotate the predicted up direction towards the measured one (body-frame rotation about
  // an axis perpendicular to up, so the heading is untouched).
  const double f_norm = s.accel.norm();
  if (std::abs(f_norm - gravity_) < options_.accel_gate_mps2) {
    const Eigen::Vector3d up_meas_b = s.accel / f_norm;
    const Eigen::Vector3d up_pred_b = q_w_b_.conjugate() * Eigen::Vector3d::UnitZ();
    const double gain = std::min(1.0, dt / options_.tilt_time_constant_s);
    const Eigen::Vector3d phi_b = gain * up_meas_b.cross(up_pred_b);
    q_w_b_ = q_w_b_ * expMap(phi_b);
    correction_b += phi_b;
  }

  // Heading: azimuth of the low-passed field in ENU (with the attitude of its own time) vs D.
  if (have_geomagnetic_ && std::abs(s.t - geomagnetic_t_) < kMaxGeomagneticAge) {
    const auto q_at_g = attitudeAt(geomagnetic_t_);
    const Eigen::Vector3d B_w = (q_at_g ? *q_at_g : q_w_b_) * geomagnetic_b_;
    const double horizontal = std::hypot(B_w.x(), B_w.y());
    if (horizontal > kMinHorizontalFieldRatio * B_w.norm()) {
      const double azimuth = std::atan2(B_w.x(), B_w.y());  // clockwise from true north
      // An attitude yawed by +e (counter-clockwise) shows the field at azimuth D - e.
      const double yaw_error = wrapPi(declination_rad_ - azimuth);
      const double gain = std::min(1.0, dt / options_.heading_time_constant_s);
      const Eigen::Vector3d phi_w = -gain * yaw_error * Eigen::Vector3d::UnitZ();
      q_w_b_ = expMap(phi_w) * q_w_b_;
      correction_b += q_w_b_.conjugate() * phi_w;
    }
  }
  // Integral part: a steady correction means the gyro reads that rate too much (bias).
  // (rate correction_b / dt integrated with gain dt / tau: the dt cancels.)
  gyro_bias_ -= correction_b / options_.gyro_bias_time_constant_s;
  if (gyro_bias_.norm() > kMaxGyroBias) gyro_bias_ *= kMaxGyroBias / gyro_bias_.norm();
  q_w_b_.normalize();
  t_state_ = s.t;
  history_.push_back({s.t, q_w_b_});
}

}  // namespace vims
