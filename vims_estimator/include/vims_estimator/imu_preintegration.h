#pragma once
/// @file imu_preintegration.h
/// @brief IMU preintegration between two keyframes (mid-point integration, bias Jacobians,
/// 15x15 covariance), the measurement of the IMU factor (factors/imu_factor.h).
///
/// Preintegrated quantities, all in the body frame b_i of the first keyframe (docs/factors.md):
///   alpha = int int R_bi_bt (a_t - b_a) dt^2      (position-like)
///   beta  = int R_bi_bt (a_t - b_a) dt            (velocity-like)
///   gamma = q_bi_bj = prod Exp((w_t - b_g) dt)    (rotation)
/// with a_t the specific force and w_t the angular rate, so that (g_w = [0, 0, -g])
///   p_j = p_i + v_i T + 1/2 g_w T^2 + R_i alpha,   v_j = v_i + g_w T + R_i beta,   q_j = q_i gamma.
///
/// Error state (ordering of covariance(), jacobian() and the IMU residual):
///   [0:3) alpha, [3:6) theta (gamma_true = gamma (x) Exp(theta)), [6:9) beta, [9:12) b_a, [12:15) b_g
/// errors being "true minus computed".

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "vims_common/config_reader.h"
#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"

namespace vims {

template <typename Options>
class OptionTable;

using Matrix15d = Eigen::Matrix<double, 15, 15>;

/// Error-state indices (see file comment).
enum ImuStateIndex : int { kIdxAlpha = 0, kIdxTheta = 3, kIdxBeta = 6, kIdxBa = 9, kIdxBg = 12 };

/// Continuous-time IMU noise model. All four must be > 0 for a usable (invertible) covariance.
struct ImuNoiseParams {
  double gyro_noise_density = 0.0;   ///< sigma_g  [rad/s/sqrt(Hz)]
  double accel_noise_density = 0.0;  ///< sigma_a  [m/s^2/sqrt(Hz)]
  double gyro_random_walk = 0.0;     ///< sigma_bg [rad/s^2/sqrt(Hz)]
  double accel_random_walk = 0.0;    ///< sigma_ba [m/s^3/sqrt(Hz)]

  /// Copies the sequence calibration. Throws std::invalid_argument naming the first value that is
  /// not > 0: a noise-free model would give an infinite-information IMU factor. (Noise-free
  /// simulated sequences must be given a model noise by the caller.)
  static ImuNoiseParams fromCalibration(const ImuCalibration& calibration);
  /// Throws std::invalid_argument if a value is not finite and > 0.
  void validate() const;
};

/// When the bias estimate moves this far from the linearisation point, the first-order bias
/// correction is no longer trusted and the caller repropagates (repropagateIfNeeded()).
struct ImuPreintegrationOptions {
  /// [m/s^2] alpha and beta are exactly linear in b_a for a fixed b_g (the rotations do not
  /// depend on b_a), so the accel correction is only spoiled through the b_a-b_g cross terms; this
  /// generous bound (VINS-Mono's value) just keeps those small.
  double max_accel_bias_change = 0.1;
  /// [rad/s] The gyro correction is first order in Exp(J dbg): its error is ~|dbg T|^2 / 2, i.e.
  /// 5e-5 rad over T = 1 s at this bound, well below the gyro white-noise share sigma_g sqrt(T)
  /// of any MEMS/FOG IMU (>= 1e-4 rad), while it avoids repropagating at every solver iteration.
  double max_gyro_bias_change = 0.01;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<ImuPreintegrationOptions>& optionTable();

  /// Reads {max_accel_bias_change, max_gyro_bias_change}; unknown keys and values <= 0 throw
  /// ConfigError naming the key. Absent keys keep the defaults.
  static ImuPreintegrationOptions fromReader(const ConfigReader& reader);
  std::string toYaml() const;
};

/// Returns the IMU samples that span exactly [t0, t1]: the first and last are linearly
/// interpolated to t0 and t1 (unless a sample falls exactly on them), the interior samples are
/// copied. `samples` must be sorted by time. Returns std::nullopt if the samples do not cover
/// [t0, t1] (first sample after t0 or last before t1), if t1 <= t0, or if a sample is not finite.
std::optional<std::vector<ImuSample>> imuSamplesForInterval(const std::vector<ImuSample>& samples, double t0,
                                                            double t1);

/// Preintegrated IMU measurement between keyframes i and j.
///
/// Usage: construct with the sample at t_i (use imuSamplesForInterval() to get exact endpoints),
/// addSample() the rest up to the sample at t_j, then build ImuFactor from it. Before each solve,
/// call repropagateIfNeeded() with the current bias estimate of keyframe i.
class ImuPreintegration {
 public:
  /// Starts an empty integration at `first.t`, linearised at the biases (b_a, b_g).
  ImuPreintegration(const ImuSample& first, const Eigen::Vector3d& ba_lin, const Eigen::Vector3d& bg_lin,
                    const ImuNoiseParams& noise);

  /// Integrates from the last sample to `sample` with the mid-point rule (any dt > 0; the rate
  /// may jitter). Returns false and ignores the sample if its time does not advance or a value
  /// is not finite: the preintegration then stays valid up to the last accepted sample.
  bool addSample(const ImuSample& sample);

  /// Convenience: constructs from samples[0] and adds the rest. Throws std::invalid_argument if
  /// `samples` has fewer than 2 entries or a sample is rejected.
  static ImuPreintegration fromSamples(const std::vector<ImuSample>& samples, const Eigen::Vector3d& ba_lin,
                                       const Eigen::Vector3d& bg_lin, const ImuNoiseParams& noise);

  /// Re-integrates all stored samples with new linearisation biases.
  void repropagate(const Eigen::Vector3d& ba_lin, const Eigen::Vector3d& bg_lin);
  /// Repropagates at (ba, bg) if either moved beyond the option thresholds from the current
  /// linearisation point; returns true if it did.
  bool repropagateIfNeeded(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg,
                           const ImuPreintegrationOptions& options);

  /// First-order bias-corrected preintegrated values at biases (ba, bg):
  ///   alpha(b) = alpha + dalpha/dba dba + dalpha/dbg dbg,   beta likewise,
  ///   gamma(b) = gamma (x) Exp(dgamma/dbg dbg),             dba = ba - ba_lin, dbg = bg - bg_lin.
  void correct(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg, Eigen::Vector3d* alpha, Eigen::Vector3d* beta,
               Eigen::Quaterniond* gamma) const;

  double startTime() const { return samples_.front().t; }
  double endTime() const { return samples_.back().t; }
  double deltaTime() const { return sum_dt_; }
  /// Number of integration steps (samples - 1).
  int numSteps() const { return static_cast<int>(samples_.size()) - 1; }

  const Eigen::Vector3d& alpha() const { return alpha_; }
  const Eigen::Vector3d& beta() const { return beta_; }
  const Eigen::Quaterniond& gamma() const { return gamma_; }
  const Eigen::Vector3d& linearizedAccelBias() const { return ba_lin_; }
  const Eigen::Vector3d& linearizedGyroBias() const { return bg_lin_; }
  /// d(error state)/d(bias) accumulated over the interval (15x15; the bias columns 9..14 hold
  /// dalpha/dba, dalpha/dbg, dtheta/dbg, dbeta/dba, dbeta/dbg).
  const Matrix15d& jacobian() const { return jacobian_; }
  /// Covariance of the 15-dim error state (see file comment).
  const Matrix15d& covariance() const { return covariance_; }
  const ImuNoiseParams& noise() const { return noise_; }
  const std::vector<ImuSample>& samples() const { return samples_; }

  Eigen::Matrix3d dAlphaDba() const { return jacobian_.block<3, 3>(kIdxAlpha, kIdxBa); }
  Eigen::Matrix3d dAlphaDbg() const { return jacobian_.block<3, 3>(kIdxAlpha, kIdxBg); }
  Eigen::Matrix3d dThetaDbg() const { return jacobian_.block<3, 3>(kIdxTheta, kIdxBg); }
  Eigen::Matrix3d dBetaDba() const { return jacobian_.block<3, 3>(kIdxBeta, kIdxBa); }
  Eigen::Matrix3d dBetaDbg() const { return jacobian_.block<3, 3>(kIdxBeta, kIdxBg); }

 private:
  void reset();
  void integrateStep(const ImuSample& s0, const ImuSample& s1);

  ImuNoiseParams noise_;
  Eigen::Vector3d ba_lin_;
  Eigen::Vector3d bg_lin_;
  std::vector<ImuSample> samples_;  ///< all accepted samples, kept for repropagation

  double sum_dt_ = 0.0;
  Eigen::Vector3d alpha_;
  Eigen::Vector3d beta_;
  Eigen::Quaterniond gamma_;
  Matrix15d jacobian_;
  Matrix15d covariance_;
};

}  // namespace vims
