#pragma once
/// @file sonar_altitude_filter.h
/// @brief Outlier and dropout filter for the single-beam sonar's slant range.
///
/// Model. Between resets the slant range is locally a straight line in time (the vehicle's
/// altitude and attitude change smoothly). The filter keeps the last `window_size` *accepted*
/// samples, fits that line by least squares, and gates each new range against the line's
/// prediction: |r - r_pred| <= gate_sigma * sqrt(sigma^2 + var(r_pred)) + bend, where sigma is
/// the sonar's range noise, var(r_pred) the least-squares prediction variance (it grows with
/// the extrapolation distance, e.g. after a dropout) and `bend` the worst-case departure of a
/// range with bounded second derivative from the line. Multipath returns are too long by
/// 30 % or more and fall outside the gate; the window only ever holds accepted samples, so a
/// rejected outlier cannot drag the trend.
///
/// Output. The filtered range of an accepted sample is a median filter that follows the trend:
/// the median over the window of r_i + slope * (t - t_i) (each sample moved along the line to
/// time t). It has no lag on a ramp, unlike a plain running median.
///
/// (Re)acquisition. With no trusted trend (start, after a gap longer than max_gap_s, after the
/// clock went backwards) samples are held back until `acquire_samples` consecutive valid
/// samples agree: each one must lie within the gate of the line fitted through the others
/// (leave-one-out), so a single outlier cannot become the new truth. On failure the sample with
/// the largest normalised disagreement is marked as an outlier and the filter waits for the
/// next sample. Held samples are emitted, in order, once their fate is known, so feed() may
/// return several results at once (at most acquire_samples - 1 samples late) or none.
///
/// Dropouts. +inf, NaN, and ranges outside [min_range, max_range] are dropouts; a missing
/// message is simply a longer interval. Neither counts as evidence; after max_gap_s without an
/// accepted sample the filter resets.

#include <deque>
#include <string>
#include <vector>

#include "vims_common/log.h"
#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sonar_altitude.h"
#include "vims_sonar/sonar_filter_options.h"

namespace vims {

/// Counters since construction (not cleared by resets).
struct SonarFilterStats {
  long samples = 0;
  long accepted = 0;
  long outliers = 0;
  long dropouts = 0;
  long warming_up = 0;  ///< includes samples with status kReset
  long resets = 0;      ///< acquisitions lost (gap or clock backwards); the first acquisition is not a reset
};

class SonarAltitudeFilter {
 public:
  /// `calibration` supplies range_noise_std and [min_range, max_range] (the sequence YAML).
  /// Throws ConfigError if `options` are invalid.
  SonarAltitudeFilter(const SonarFilterOptions& options, const SonarCalibration& calibration,
                      LoggerPtr logger = Logger::nullLogger());

  /// Feeds one range (in time order; a stamp going backwards resets the filter with a warning).
  /// Appends to `results` the verdicts that became final, in input order.
  void feed(const SonarRange& sample, std::vector<SonarFilterResult>* results);

  /// Emits the verdicts of samples still held for acquisition (as warming up), e.g. at the end
  /// of a bag, so every input sample has exactly one result.
  void flush(std::vector<SonarFilterResult>* results);

  /// Drops the trend and any held samples (their results are discarded).
  void reset();

  bool locked() const { return locked_; }
  const SonarFilterStats& stats() const { return stats_; }
  const SonarFilterOptions& options() const { return options_; }
  /// The range noise the gate uses: max(range_noise_std, min_noise_std_m) [m].
  double noiseStd() const { return sigma_; }

 private:
  struct Sample {
    double t;
    double r;
  };
  /// Least-squares line through samples, evaluated relative to their mean time.
  struct Line {
    double t_mean = 0.0;
    double r_mean = 0.0;
    double slope = 0.0;
    double sxx = 0.0;  ///< sum (t_i - t_mean)^2
    int n = 0;
    double at(double t) const { return r_mean + slope * (t - t_mean); }
  };
  struct Pending {
    SonarFilterResult result;
    bool candidate = false;      ///< valid and not yet rejected: takes part in acquisition
    bool reset_trigger = false;  ///< first sample after a reset: reported as kReset unless accepted
  };

  /// Least-squares line through `samples`, leaving out index `skip` (-1: use all).
  static Line fitLine(const std::vector<Sample>& samples, int skip);
  /// Gate half-width for a range at time t predicted by `line`.
  double gate(const Line& line, double t) const;
  double trendMedian(const std::vector<Sample>& window, double slope, double t) const;
  bool validRange(double r) const;

  void feedLocked(const SonarRange& sample, bool valid, std::vector<SonarFilterResult>* results);
  void feedAcquiring(const SonarRange& sample, bool valid);
  void tryAcquire();
  /// Drops the trend (or the held samples, emitting them) and marks the next sample as a reset.
  void startReset(double t, const std::string& why, std::vector<SonarFilterResult>* results);
  /// Emits held samples from the front of pending_ whose verdict is final.
  void emitFinal(std::vector<SonarFilterResult>* results);
  void emit(SonarFilterResult r, bool reset_trigger, std::vector<SonarFilterResult>* results);

  SonarFilterOptions options_;
  double sigma_;
  double min_range_;
  double max_range_;
  /// max_gap_s, but at least acquire_samples + 1 sample periods of the sequence's sonar rate:
  /// acquisition must fit its samples, and one lost sample must not reset a slow sonar.
  double max_gap_s_;
  LoggerPtr logger_;

  bool locked_ = false;
  bool have_last_t_ = false;
  double last_t_ = 0.0;
  bool next_is_reset_ = false;   ///< the next held sample is a reset trigger
  std::vector<Sample> window_;   ///< accepted samples, oldest first (locked mode)
  std::deque<Pending> pending_;  ///< held samples (acquisition mode), in input order
  SonarFilterStats stats_;
};

}  // namespace vims
