#pragma once
/// @file attitude_filter.h
/// @brief A small AHRS (complementary filter) giving the body attitude in true ENU, q_w_b, for
/// rotating the magnetometer's alternating field into ENU sample by sample.
///
/// Why its own attitude and not the VIO's: a magnetic signature must be comparable when the same
/// spot is passed again with another heading, possibly hours later. The VIO's yaw is
/// unobservable and drifts; the geomagnetic field gives an absolute heading that does not.
/// The AUV barely accelerates, so the accelerometer gives roll and pitch.
///
///  - Propagation: q_w_b <- q_w_b * Exp((gyro - bias) * dt) at every IMU sample.
///  - Tilt: the measured specific-force direction f_b/|f_b| (gravity "up" in the body) pulls the
///    predicted up direction R_w_b^T e_z towards it with time constant tilt_time_constant_s,
///    by a body-frame rotation perpendicular to up (it cannot change the heading). Skipped while
///    | |f| - g | > accel_gate_mps2.
///  - Heading: the low-passed geomagnetic field B_b (the moving average centred at t_g, i.e.
///    delayed by half its length) is rotated into ENU with the attitude *at t_g* from the
///    history; its horizontal azimuth must equal the site's declination D. The yaw error
///    (D - azimuth) is removed with time constant heading_time_constant_s by a rotation about
///    world up (it cannot change roll or pitch).
///  - Gyro bias: both corrections, expressed as a body-frame rate, are integrated into the bias
///    estimate with time constant gyro_bias_time_constant_s (the integral part of a Mahony-type
///    PI complementary filter), so a constant bias leaves no steady attitude error.
///  - Initialisation (TRIAD): at the first geomagnetic value, from the mean specific force around
///    t_g and B_b: up_b = f/|f|, east_b = B_b x up_b (normalised), north_b = up_b x east_b gives
///    the attitude in magnetic ENU, then a rotation of -D about up gives true ENU. Buffered IMU
///    samples after t_g are then integrated so the attitude is current.
///
/// attitudeAt(t) interpolates (slerp) a short history so that callers working with delayed
/// samples (the centred moving average) get the attitude of the sample's own time.

#include <Eigen/Geometry>
#include <deque>
#include <optional>

#include "vims_common/log.h"
#include "vims_common/sensor_data.h"
#include "vims_magnetometer/magnetometer_options.h"

namespace vims {

class AttitudeFilter {
 public:
  /// `gravity` [m/s^2] (sequence imu.gravity), `declination_rad` east positive, `history_s` how
  /// far back attitudeAt() must reach.
  AttitudeFilter(const AttitudeFilterOptions& options, double gravity, double declination_rad, double history_s,
                 LoggerPtr logger = Logger::nullLogger());

  /// IMU samples in time order; a stamp going backwards resets the filter (warning), a gap
  /// longer than max_imu_gap_s re-initialises it, non-finite samples are ignored (warning).
  void feedImu(const ImuSample& sample);
  /// The low-passed geomagnetic field in the body frame [T], valid at time t.
  void feedGeomagnetic(double t, const Eigen::Vector3d& B_b);

  bool initialized() const { return initialized_; }
  /// q_w_b at time t, interpolated from the history; nullopt before initialisation, outside the
  /// history, or more than max_imu_gap_s after the newest IMU sample.
  std::optional<Eigen::Quaterniond> attitudeAt(double t) const;
  /// The newest attitude (identity before initialisation) and its time.
  const Eigen::Quaterniond& current() const { return q_w_b_; }
  double currentTime() const { return t_state_; }
  /// Current gyro-bias estimate [rad/s] (kept across re-initialisations, cleared by reset()).
  const Eigen::Vector3d& gyroBias() const { return gyro_bias_; }
  long initializations() const { return initializations_; }
  void reset();

  /// TRIAD attitude q_w_b from the specific force f_b (points up at rest) and the geomagnetic
  /// field B_b in the body frame, for a site with declination D. nullopt when f_b and B_b are
  /// (nearly) parallel or zero.
  static std::optional<Eigen::Quaterniond> fromGravityAndField(const Eigen::Vector3d& f_b, const Eigen::Vector3d& B_b,
                                                               double declination_rad);

 private:
  struct Entry {
    double t;
    Eigen::Quaterniond q_w_b;
  };
  void tryInitialize();
  void propagate(const ImuSample& sample);
  void trim(double t_newest);

  AttitudeFilterOptions options_;
  double gravity_;
  double declination_rad_;
  double history_s_;
  LoggerPtr logger_;

  bool initialized_ = false;
  Eigen::Quaterniond q_w_b_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d gyro_bias_ = Eigen::Vector3d::Zero();
  double t_state_ = 0.0;
  bool have_last_imu_ = false;
  double last_imu_t_ = 0.0;
  std::deque<ImuSample> imu_buffer_;  ///< recent raw samples, for (re)initialisation
  std::deque<Entry> history_;
  bool have_geomagnetic_ = false;
  double geomagnetic_t_ = 0.0;
  Eigen::Vector3d geomagnetic_b_ = Eigen::Vector3d::Zero();
  long initializations_ = 0;
};

}  // namespace vims
