#include "vims_estimator/imu_preintegration.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "vims_common/option_table.h"
#include "vims_estimator/so3.h"

namespace vims {

namespace {

bool isFinite(const ImuSample& s) { return std::isfinite(s.t) && s.gyro.allFinite() && s.accel.allFinite(); }

ImuSample lerp(const ImuSample& a, const ImuSample& b, double t) {
  const double s = (t - a.t) / (b.t - a.t);
  ImuSample out;
  out.t = t;
  out.gyro = (1.0 - s) * a.gyro + s * b.gyro;
  out.accel = (1.0 - s) * a.accel + s * b.accel;
  return out;
}

void requirePositiveFinite(double value, const char* name) {
  if (!(std::isfinite(value) && value > 0.0)) {
    throw std::invalid_argument(std::string("ImuNoiseParams: ") + name + " must be > 0 (got " + std::to_string(value) +
                                ")");
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Noise and options
// ---------------------------------------------------------------------------------------------

ImuNoiseParams ImuNoiseParams::fromCalibration(const ImuCalibration& calibration) {
  ImuNoiseParams p;
  p.gyro_noise_density = calibration.gyro_noise_density;
  p.accel_noise_density = calibration.accel_noise_density;
  p.gyro_random_walk = calibration.gyro_random_walk;
  p.accel_random_walk = calibration.accel_random_walk;
  p.validate();
  return p;
}

void ImuNoiseParams::validate() const {
  requirePositiveFinite(gyro_noise_density, "gyro_noise_density");
  requirePositiveFinite(accel_noise_density, "accel_noise_density");
  requirePositiveFinite(gyro_random_walk, "gyro_random_walk");
  requirePositiveFinite(accel_random_walk, "accel_random_walk");
}

const OptionTable<ImuPreintegrationOptions>& ImuPreintegrationOptions::optionTable() {
  using O = ImuPreintegrationOptions;
  static const auto table = OptionTable<O>()
                                .number("max_accel_bias_change", &O::max_accel_bias_change, Bounds::positive())
                                .number("max_gyro_bias_change", &O::max_gyro_bias_change, Bounds::positive());
  return table;
}

ImuPreintegrationOptions ImuPreintegrationOptions::fromReader(const ConfigReader& reader) {
  return readOptions<ImuPreintegrationOptions>(reader);
}

std::string ImuPreintegrationOptions::toYaml() const { return optionTable().toYaml(*this); }

// ---------------------------------------------------------------------------------------------
// Interval extraction
// ---------------------------------------------------------------------------------------------

std::optional<std::vector<ImuSample>> imuSamplesForInterval(const std::vector<ImuSample>& samples, double t0,
                                                            double t1) {
  if (!(std::isfinite(t0) && std::isfinite(t1)) || t1 <= t0 || samples.empty()) return std::nullopt;
  if (samples.front().t > t0 || samples.back().t < t1) return std::nullopt;

  // Last sample at or before t0 and first sample at or after t1.
  size_t i0 = 0;
  while (i0 + 1 < samples.size() && samples[i0 + 1].t <= t0) ++i0;
  size_t i1 = i0;
  while (samples[i1].t < t1) ++i1;  // terminates: samples.back().t >= t1

  for (size_t i = i0; i <= i1; ++i) {
    if (!isFinite(samples[i])) return std::nullopt;
    if (i > i0 && samples[i].t <= samples[i - 1].t) return std::nullopt;  // must strictly increase
  }

  std::vector<ImuSample> out;
  out.reserve(i1 - i0 + 1);
  out.push_back(samples[i0].t == t0 ? samples[i0] : lerp(samples[i0], samples[i0 + 1], t0));
  for (size_t i = i0 + 1; i < i1; ++i) out.push_back(samples[i]);
  out.push_back(samples[i1].t == t1 ? samples[i1] : lerp(samples[i1 - 1], samples[i1], t1));
  return out;
}

// ---------------------------------------------------------------------------------------------
// Preintegration
// ---------------------------------------------------------------------------------------------

ImuPreintegration::ImuPreintegration(const ImuSample& first, const Eigen::Vector3d& ba_lin,
                                     const Eigen::Vector3d& bg_lin, const ImuNoiseParams& noise)
    : noise_(noise), ba_lin_(ba_lin), bg_lin_(bg_lin) {
  noise_.validate();
  if (!isFinite(first)) throw std::invalid_argument("ImuPreintegration: first sample is not finite");
  samples_.push_back(first);
  reset();
}

ImuPreintegration ImuPreintegration::fromSamples(const std::vector<ImuSample>& samples, const Eigen::Vector3d& ba_lin,
                                                 const Eigen::Vector3d& bg_lin, const ImuNoiseParams& noise) {
  if (samples.size() < 2) throw std::invalid_argument("ImuPreintegration::fromSamples: need >= 2 samples");
  ImuPreintegration pre(samples.front(), ba_lin, bg_lin, noise);
  for (size_t i = 1; i < samples.size(); ++i) {
    if (!pre.addSample(samples[i])) {
      throw std::invalid_argument("ImuPreintegration::fromSamples: sample " + std::to_string(i) +
                                  " is not finite or does not advance in time");
    }
  }
  return pre;
}

void ImuPreintegration::reset() {
  sum_dt_ = 0.0;
  alpha_.setZero();
  beta_.setZero();
  gamma_.setIdentity();
  jacobian_.setIdentity();
  covariance_.setZero();
}

bool ImuPreintegration::addSample(const ImuSample& sample) {
  if (!isFinite(sample) || !(sample.t > samples_.back().t)) return false;
  integrateStep(samples_.back(), sample);
  samples_.push_back(sample);
  return true;
}

void ImuPreintegration::repropagate(const Eigen::Vector3d& ba_lin, const Eigen::Vector3d& bg_lin) {
  ba_lin_ = ba_lin;
  bg_lin_ = bg_lin;
  reset();
  for (size_t i = 1; i < samples_.size(); ++i) integrateStep(samples_[i - 1], samples_[i]);
}

bool ImuPreintegration::repropagateIfNeeded(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg,
                                            const ImuPreintegrationOptions& options) {
  if ((ba - ba_lin_).norm() <= options.max_accel_bias_change && (bg - bg_lin_).norm() <= options.max_gyro_bias_change)
    return false;
  repropagate(ba, bg);
  return true;
}

void ImuPreintegration::correct(const Eigen::Vector3d& ba, const Eigen::Vector3d& bg, Eigen::Vector3d* alpha,
                                Eigen::Vector3d* beta, Eigen::Quaterniond* gamma) const {
  const Eigen::Vector3d dba = ba - ba_lin_;
  const Eigen::Vector3d dbg = bg - bg_lin_;
  if (alpha) *alpha = alpha_ + dAlphaDba() * dba + dAlphaDbg() * dbg;
  if (beta) *beta = beta_ + dBetaDba() * dba + dBetaDbg() * dbg;
  if (gamma) *gamma = (gamma_ * so3::exp(dThetaDbg() * dbg)).normalized();
}

// One mid-point step from s0 to s1 (dt = s1.t - s0.t). With R0 = R(gamma_k), R1 = R(gamma_k+1),
// a0 = acc0 - b_a, a1 = acc1 - b_a, w = (gyr0 + gyr1)/2 - b_g:
//   gamma_k+1 = gamma_k (x) Exp(w dt)
//   alpha_k+1 = alpha_k + beta_k dt + 1/4 (R0 a0 + R1 a1) dt^2
//   beta_k+1  = beta_k + 1/2 (R0 a0 + R1 a1) dt
// Error propagation x_k+1 = F x_k + G n (errors "true minus computed", theta right-perturbation).
// With Rinc = Exp(w dt), Jr = Jr(w dt) and the true rotation error
//   theta_k+1 = Rinc^T theta_k - Jr dt dbg - Jr dt n_g
// the error of the averaged acceleration (R0 a0 + R1 a1)/2 is 1/2 (S_th theta_k + S_ba dba + S_bg dbg)
//   S_th = -R0 [a0]x - R1 [a1]x Rinc^T,   S_ba = -(R0 + R1),   S_bg = R1 [a1]x Jr dt,
// and it enters beta with dt and alpha with dt^2/2. The noise n = [n_a, n_g, n_ba, n_bg] is the
// white noise of the step's averaged measurement (variance sigma^2/dt: a density integrated over
// dt) and the bias random-walk increments (variance sigma_rw^2 dt). This discretisation is what
// makes the propagated covariance independent of the IMU rate.
void ImuPreintegration::integrateStep(const ImuSample& s0, const ImuSample& s1) {
  const double dt = s1.t - s0.t;
  const Eigen::Vector3d w = 0.5 * (s0.gyro + s1.gyro) - bg_lin_;
  const Eigen::Vector3d a0 = s0.accel - ba_lin_;
  const Eigen::Vector3d a1 = s1.accel - ba_lin_;

  const Eigen::Vector3d wdt = w * dt;
  const Eigen::Quaterniond dq = so3::exp(wdt);
  const Eigen::Matrix3d R_inc = dq.toRotationMatrix();
  const Eigen::Matrix3d R0 = gamma_.toRotationMatrix();
  const Eigen::Quaterniond gamma1 = (gamma_ * dq).normalized();
  const Eigen::Matrix3d R1 = gamma1.toRotationMatrix();

  const Eigen::Vector3d acc_mid = 0.5 * (R0 * a0 + R1 * a1);
  alpha_ += beta_ * dt + 0.5 * acc_mid * dt * dt;
  beta_ += acc_mid * dt;
  gamma_ = gamma1;
  sum_dt_ += dt;

  const Eigen::Matrix3d I3 = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d Jr = so3::rightJacobian(wdt);
  const Eigen::Matrix3d S_th = -R0 * so3::skew(a0) - R1 * so3::skew(a1) * R_inc.transpose();
  const Eigen::Matrix3d S_ba = -(R0 + R1);
  const Eigen::Matrix3d S_bg = R1 * so3::skew(a1) * Jr * dt;
  const double h_a = 0.25 * dt * dt;  // weight of the summed acceleration error in alpha
  const double h_b = 0.5 * dt;        // ... in beta

  Matrix15d F = Matrix15d::Identity();
  F.block<3, 3>(kIdxAlpha, kIdxTheta) = h_a * S_th;
  F.block<3, 3>(kIdxAlpha, kIdxBeta) = I3 * dt;
  F.block<3, 3>(kIdxAlpha, kIdxBa) = h_a * S_ba;
  F.block<3, 3>(kIdxAlpha, kIdxBg) = h_a * S_bg;
  F.block<3, 3>(kIdxTheta, kIdxTheta) = R_inc.transpose();
  F.block<3, 3>(kIdxTheta, kIdxBg) = -Jr * dt;
  F.block<3, 3>(kIdxBeta, kIdxTheta) = h_b * S_th;
  F.block<3, 3>(kIdxBeta, kIdxBa) = h_b * S_ba;
  F.block<3, 3>(kIdxBeta, kIdxBg) = h_b * S_bg;

  Eigen::Matrix<double, 15, 12> G = Eigen::Matrix<double, 15, 12>::Zero();
  G.block<3, 3>(kIdxAlpha, 0) = h_a * S_ba;  // n_a shifts both accelerations: same as a bias error
  G.block<3, 3>(kIdxBeta, 0) = h_b * S_ba;
  G.block<3, 3>(kIdxTheta, 3) = -Jr * dt;  // n_g shifts the mid-point rate: same as a bias error
  G.block<3, 3>(kIdxAlpha, 3) = h_a * S_bg;
  G.block<3, 3>(kIdxBeta, 3) = h_b * S_bg;
  G.block<3, 3>(kIdxBa, 6) = I3;
  G.block<3, 3>(kIdxBg, 9) = I3;

  Eigen::Matrix<double, 12, 1> q;
  q.segment<3>(0).setConstant(noise_.accel_noise_density * noise_.accel_noise_density / dt);
  q.segment<3>(3).setConstant(noise_.gyro_noise_density * noise_.gyro_noise_density / dt);
  q.segment<3>(6).setConstant(noise_.accel_random_walk * noise_.accel_random_walk * dt);
  q.segment<3>(9).setConstant(noise_.gyro_random_walk * noise_.gyro_random_walk * dt);

  jacobian_ = F * jacobian_;
  covariance_ = F * covariance_ * F.transpose() + G * q.asDiagonal() * G.transpose();
  covariance_ = 0.5 * (covariance_ + covariance_.transpose());  // keep it exactly symmetric
}

}  // namespace vims
