#include "vims_magnetometer/signature_extractor.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <iomanip>

namespace vims {
namespace {
constexpr const char* kComponent = "mag_signature";
/// An SNR with (numerically) no noise at all is reported as this instead of infinity.
constexpr double kMaxSnr = 1e12;
// Frequency-tracking probes this many bins either side of the coil's: inside the Hann main lobe
// (+-2 bins), where its log is nearly a parabola, and far enough apart to read its slope.
constexpr double kProbeBins = 0.5;
// A moving average over whole periods of f0 leaves a fraction ~|f - f0| / f0 of a coil at f in
// the geomagnetic estimate, and so takes it from the alternating field; past 0.5 % it is rebuilt
// for the tracked frequency (0.055 Hz at 11 Hz: a 0.1 Hz drift costs two 3 s refills).
constexpr double kMovingAverageRebuildFraction = 0.005;
// Only windows this many times above min_snr move the frequency: there the coil dominates its
// bin by 30 dB, so a weaker line passing close (a thruster's) cannot drag the tracking along.
constexpr double kTrackingSnrFactor = 10.0;

/// The extractor is built for one known frequency (MagneticFrontEnd finds an unknown one first).
double knownCoilFrequency(const MagnetometerCalibration& calibration) {
  if (!calibration.coilFrequencyKnown()) {
    throw ConfigError("magnetometer: the signature extractor needs the coil frequency (MagneticFrontEnd finds it)");
  }
  return calibration.coil_frequency_hz;
}
}  // namespace

MovingAverageLength chooseMovingAverage(double rate_hz, double coil_frequency_hz, int min_periods) {
  MovingAverageLength best;
  best.residual = 1e300;
  for (int m = std::max(1, min_periods); m <= 4 * std::max(1, min_periods); ++m) {
    const double exact = m * rate_hz / coil_frequency_hz;
    const int n = static_cast<int>(std::lround(exact));
    const double residual = std::abs(exact - n);
    if (n >= 2 && residual < best.residual - 1e-9) {
      best = {m, n, residual};
      if (residual < 1e-6) break;
    }
  }
  return best;
}

SignatureExtractor::SignatureExtractor(const MagnetometerOptions& options, const MagnetometerCalibration& calibration,
                                       double gravity, LoggerPtr logger, int coil)
    : options_(options),
      calibration_(calibration),
      R_b_m_(calibration.T_b_m.linear()),
      logger_(logger ? std::move(logger) : Logger::nullLogger()),
      coil_(coil),
      attitude_(options.attitude, gravity, calibration.declination_deg * M_PI / 180.0,
                // attitudeAt() must reach back to the centre of the moving average, plus margin.
                0.5 * options.geomagnetic_min_periods * 4.0 / knownCoilFrequency(calibration) + 1.0, logger_) {
  options_.validateFor(calibration_, ConfigReader::fromString("", "magnetometer options"));
  moving_average_ =
      chooseMovingAverage(calibration_.rate_hz, calibration_.coil_frequency_hz, options_.geomagnetic_min_periods);
  window_samples_ = static_cast<int>(std::lround(options_.window_s * calibration_.rate_hz));
  hop_samples_ = std::max(1, static_cast<int>(std::lround(options_.hop_s * calibration_.rate_hz)));
  // Periodic Hann window: its sidelobes fall as 1/f^3, so the slow residual of the geomagnetic
  // separation (vehicle turning) does not leak into the coil bin.
  hann_.resize(window_samples_);
  for (int n = 0; n < window_samples_; ++n) {
    hann_[n] = 0.5 - 0.5 * std::cos(2.0 * M_PI * n / window_samples_);
    hann_sum_ += hann_[n];
  }
  const double window_s = static_cast<double>(window_samples_) / calibration_.rate_hz;
  nominal_frequency_hz_ = calibration_.coil_frequency_hz;
  frequency_hz_ = nominal_frequency_hz_;
  moving_average_frequency_hz_ = nominal_frequency_hz_;
  stats_.frequency_hz = frequency_hz_;
  offsets_.push_back(0.0);
  for (int k = options_.snr_inner_bins; k <= options_.snr_outer_bins; ++k) {
    offsets_.push_back(-k / window_s);
    offsets_.push_back(k / window_s);
  }
  noise_bins_ = offsets_.size() - 1;
  if (options_.frequency_tracking_time_constant_s > 0.0) {
    offsets_.push_back(-kProbeBins / window_s);
    offsets_.push_back(kProbeBins / window_s);
  }
  raw_.resize(moving_average_.samples);
  alt_.resize(window_samples_);
  logger_->info(kComponent, VIMS_STR("geomagnetic moving average: "
                                     << moving_average_.samples << " samples = " << moving_average_.periods
                                     << " coil periods (residual " << moving_average_.residual << " samples); window "
                                     << window_samples_ << " samples, hop " << hop_samples_));
}

void SignatureExtractor::reset() {
  raw_count_ = 0;
  raw_sum_.setZero();
  raw_gap_count_ = 0;
  raw_nonfinite_count_ = 0;
  alt_count_ = 0;
  have_last_t_ = false;
  have_geomagnetic_output_ = false;
}

void SignatureExtractor::feedMag(const MagSample& sample, std::vector<SignatureWindow>* signatures,
                                 std::vector<GeomagneticSample>* geomagnetic) {
  ++stats_.mag_samples;
  if (rebuild_moving_average_) {
    rebuild_moving_average_ = false;
    moving_average_frequency_hz_ = frequency_hz_;
    moving_average_ = chooseMovingAverage(calibration_.rate_hz, frequency_hz_, options_.geomagnetic_min_periods);
    raw_.assign(moving_average_.samples, RawSlot{});
    reset();
    logger_->info(kComponent,
                  VIMS_STR(std::fixed << std::setprecision(4) << "coil frequency tracked to " << frequency_hz_
                                      << " Hz: moving average rebuilt (" << moving_average_.samples << " samples)"));
  }
  const double t = sample.t;
  if (!std::isfinite(t)) {
    logger_->warnThrottled(kComponent, "stamp", have_last_t_ ? last_t_ : 0.0, 5.0,
                           "magnetometer sample with a non-finite stamp ignored");
    return;
  }
  const double dt_nominal = 1.0 / calibration_.rate_hz;
  if (have_last_t_) {
    const double dt = t - last_t_;
    if (dt < -0.5 * dt_nominal) {
      logger_->warn(kComponent,
                    VIMS_STR("magnetometer clock went backwards by " << -dt << " s; restarting the pipeline"));
      ++stats_.resets;
      reset();
    } else {
      const long steps = std::lround(dt / dt_nominal);
      if (steps <= 0) {
        ++stats_.duplicates;
        logger_->warnThrottled(kComponent, "duplicate", t, 5.0, "repeated magnetometer stamp dropped");
        return;
      }
      const long missing = steps - 1;
      if (missing > 0 && missing * dt_nominal > options_.max_fill_gap_s) {
        logger_->warn(kComponent, VIMS_STR("magnetometer gap of " << dt << " s at t=" << std::fixed << t
                                                                  << "; restarting the pipeline"));
        ++stats_.resets;
        reset();
      } else if (missing > 0) {
        logger_->warnThrottled(kComponent, "gap", t, 5.0,
                               VIMS_STR(missing << " magnetometer samples missing before t=" << std::fixed << t));
        stats_.filled_slots += missing;
        for (long k = 1; k <= missing; ++k) {
          pushRaw(last_t_ + dt * k / steps, Eigen::Vector3d::Zero(), kSignatureGap, geomagnetic, signatures);
        }
      }
    }
  }
  have_last_t_ = true;
  last_t_ = t;
  const bool finite = sample.field.allFinite();
  if (!finite) {
    ++stats_.nonfinite;
    logger_->warnThrottled(kComponent, "nonfinite", t, 5.0, "non-finite magnetometer sample");
  }
  pushRaw(t, finite ? sample.field : Eigen::Vector3d::Zero(), finite ? 0u : kSignatureNonFinite, geomagnetic,
          signatures);
}

void SignatureExtractor::pushRaw(double t, const Eigen::Vector3d& B_m, unsigned flags,
                                 std::vector<GeomagneticSample>* geomagnetic,
                                 std::vector<SignatureWindow>* signatures) {
  const int n_ma = moving_average_.samples;
  RawSlot& slot = raw_[raw_count_ % n_ma];
  if (raw_count_ >= n_ma) {  // the slot leaves the average
    raw_sum_ -= slot.B_m;
    if (slot.flags & kSignatureGap) --raw_gap_count_;
    if (slot.flags & kSignatureNonFinite) --raw_nonfinite_count_;
  }
  slot = {t, B_m, flags};
  raw_sum_ += B_m;
  if (flags & kSignatureGap) ++raw_gap_count_;
  if (flags & kSignatureNonFinite) ++raw_nonfinite_count_;
  ++raw_count_;
  if (raw_count_ % n_ma == 0) {
    // Re-sum once per length so rounding in the running sum cannot accumulate.
    raw_sum_.setZero();
    for (const RawSlot& s : raw_) raw_sum_ += s.B_m;
  }
  if (raw_count_ < n_ma) return;

  const RawSlot& centre = raw_[(raw_count_ - 1 - n_ma / 2) % n_ma];
  AltSlot alt{centre.t, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0u};
  if (raw_gap_count_ > 0) alt.flags |= kSignatureGap;
  if (raw_nonfinite_count_ > 0) alt.flags |= kSignatureNonFinite;
  if (alt.flags == 0) {
    const Eigen::Vector3d mean_m = raw_sum_ / n_ma;
    alt.B_geo_b = R_b_m_ * mean_m;
    attitude_.feedGeomagnetic(centre.t, alt.B_geo_b);
    const double period = options_.geomagnetic_output_period_s;
    if (!have_geomagnetic_output_ || centre.t - last_geomagnetic_output_t_ >= period - 0.5 / calibration_.rate_hz) {
      have_geomagnetic_output_ = true;
      last_geomagnetic_output_t_ = centre.t;
      if (geomagnetic) {
        geomagnetic->push_back({centre.t, alt.B_geo_b, calibration_.noise_std / std::sqrt(static_cast<double>(n_ma))});
      }
    }
    const auto q_w_b = attitude_.attitudeAt(centre.t);
    if (q_w_b) {
      alt.b_w = *q_w_b * (R_b_m_ * (centre.B_m - mean_m));
    } else {
      alt.flags |= kSignatureNoAttitude;
      alt.B_geo_b.setZero();
    }
  }
  pushAlt(alt, signatures);
}

void SignatureExtractor::pushAlt(const AltSlot& slot, std::vector<SignatureWindow>* signatures) {
  alt_[alt_count_ % window_samples_] = slot;
  ++alt_count_;
  if (alt_count_ < window_samples_ || (alt_count_ - window_samples_) % hop_samples_ != 0) return;
  double peak_offset_hz = 0.0;
  const SignatureWindow sig = computeWindow(&peak_offset_hz);
  ++stats_.windows;
  if (sig.valid) {
    ++stats_.valid_windows;
    if (sig.snr >= kTrackingSnrFactor * options_.min_snr) trackFrequency(peak_offset_hz);
  }
  if (signatures) signatures->push_back(sig);
}

void SignatureExtractor::trackFrequency(double peak_offset_hz) {
  if (options_.frequency_tracking_time_constant_s <= 0.0) return;
  // A first-order loop: the peak offset decays with the time constant; a drift of r Hz/s leaves
  // a lag of r * time constant (0.1 Hz over 10 minutes: 2 mHz at 10 s).
  const double gain = std::min(1.0, options_.hop_s / options_.frequency_tracking_time_constant_s);
  const double max = options_.frequency_tracking_max_offset_hz;
  frequency_hz_ =
      std::clamp(frequency_hz_ + gain * peak_offset_hz, nominal_frequency_hz_ - max, nominal_frequency_hz_ + max);
  stats_.frequency_hz = frequency_hz_;
  if (std::abs(frequency_hz_ - moving_average_frequency_hz_) >
      kMovingAverageRebuildFraction * moving_average_frequency_hz_)
    rebuild_moving_average_ = true;
}

SignatureWindow SignatureExtractor::computeWindow(double* peak_offset_hz) const {
  const int W = window_samples_;
  const long first = alt_count_ - W;  // index of the oldest slot in the window
  const std::size_t n_freq = offsets_.size();
  std::vector<double> frequencies(n_freq);
  for (std::size_t k = 0; k < n_freq; ++k) frequencies[k] = frequency_hz_ + offsets_[k];
  // Goertzel state per frequency and axis: s1, s2.
  std::vector<Eigen::Vector3d> s1(n_freq, Eigen::Vector3d::Zero()), s2(n_freq, Eigen::Vector3d::Zero());
  std::vector<double> coeff(n_freq);
  for (std::size_t k = 0; k < n_freq; ++k) {
    coeff[k] = 2.0 * std::cos(2.0 * M_PI * frequencies[k] / calibration_.rate_hz);
  }
  unsigned flags = 0;
  Eigen::Vector3d geo_sum = Eigen::Vector3d::Zero();
  int geo_n = 0;
  for (int n = 0; n < W; ++n) {
    const AltSlot& slot = alt_[(first + n) % W];
    flags |= slot.flags;
    if (slot.flags == 0) {
      geo_sum += slot.B_geo_b;
      ++geo_n;
    }
    const Eigen::Vector3d x = hann_[n] * slot.b_w;
    for (std::size_t k = 0; k < n_freq; ++k) {
      const Eigen::Vector3d s0 = x + coeff[k] * s1[k] - s2[k];
      s2[k] = s1[k];
      s1[k] = s0;
    }
  }
  // Goertzel output y = s1 - e^{-jw} s2 equals the DTFT up to a phase common to all axes, which
  // cancels in the relative phases below.
  auto dtft = [&](std::size_t k, int axis) {
    const double w = 2.0 * M_PI * frequencies[k] / calibration_.rate_hz;
    return std::complex<double>(s1[k][axis] - std::cos(w) * s2[k][axis], std::sin(w) * s2[k][axis]);
  };
  std::complex<double> X[3];
  double coil_power = 0.0;
  int dominant = 0;
  for (int a = 0; a < 3; ++a) {
    X[a] = dtft(0, a);
    coil_power += std::norm(X[a]);
    if (std::abs(X[a]) > std::abs(X[dominant])) dominant = a;
  }
  double noise_power = 0.0;
  for (std::size_t k = 1; k <= noise_bins_; ++k) {
    for (int a = 0; a < 3; ++a) noise_power += std::norm(dtft(k, a));
  }
  noise_power /= static_cast<double>(noise_bins_);
  *peak_offset_hz = 0.0;
  if (n_freq == noise_bins_ + 3) {
    // The peak of the summed power from the coil's bin and the probes at +-d: a parabola through
    // the log powers (the Hann main lobe is nearly Gaussian there), exact when the peak is at 0.
    double probe[2] = {0.0, 0.0};
    for (int side = 0; side < 2; ++side)
      for (int a = 0; a < 3; ++a) probe[side] += std::norm(dtft(noise_bins_ + 1 + side, a));
    const double y0 = std::log(coil_power), ym = std::log(probe[0]), yp = std::log(probe[1]);
    const double curvature = 2.0 * y0 - ym - yp;
    const double d = offsets_[noise_bins_ + 2];
    if (std::isfinite(curvature) && curvature > 0.0 && std::isfinite(yp - ym))
      *peak_offset_hz = std::clamp(0.5 * d * (yp - ym) / curvature, -d, d);
  }

  SignatureWindow sig;
  const AltSlot& oldest = alt_[first % W];
  const AltSlot& newest = alt_[(alt_count_ - 1) % W];
  sig.t_start = oldest.t;
  sig.t_end = newest.t;
  sig.t = 0.5 * (oldest.t + newest.t);
  sig.coil = coil_;
  sig.frequency_hz = frequency_hz_;
  const double dominant_abs = std::abs(X[dominant]);
  if (dominant_abs > 0.0) {
    const std::complex<double> reference = std::conj(X[dominant]) / dominant_abs;
    for (int a = 0; a < 3; ++a) sig.amplitude_enu[a] = 2.0 * (X[a] * reference).real() / hann_sum_;
  }
  if (geo_n > 0) sig.geomagnetic_body = geo_sum / geo_n;
  sig.snr = noise_power > 0.0 ? std::min(kMaxSnr, coil_power / noise_power) : (coil_power > 0.0 ? kMaxSnr : 0.0);
  if (sig.snr < options_.min_snr) flags |= kSignatureLowSnr;
  sig.flags = flags;
  sig.valid = flags == 0;
  return sig;
}

}  // namespace vims
