#pragma once
/// @file sonar_filter_options.h
/// @brief Algorithm parameters of the sonar altitude filter (vims_sonar/sonar_altitude_filter.h).
///
/// The sensor's own calibration (noise, min/max range) is *not* here: it comes from the sequence
/// YAML (SonarCalibration). These are the filter's tuning knobs; defaults and the reason for each
/// are repeated in config/sonar.yaml.

#include <string>

#include "vims_common/config_reader.h"

namespace vims {

template <typename Options>
class OptionTable;

struct SonarFilterOptions {
  /// Accepted samples in the trend window, whose detrended median is the filtered output.
  /// 7 samples = 0.6 s at the contract's 10 Hz: long enough for the median to ignore one bad
  /// sample that slipped through, short enough that a straight line follows the slant range
  /// while the vehicle changes altitude or pitches.
  int window_size = 7;
  /// Gate half-width in standard deviations of (measurement - trend prediction). The
  /// measurement and the prediction uncertainty are both in that standard deviation, so 4.5
  /// loses about 7e-6 of the good samples while multipath returns (>= 30 % too long) lie far
  /// outside it at any altitude above ~0.5 m.
  double gate_sigma = 4.5;
  /// Floor for the sequence's range_noise_std [m]. A sequence that states 0 (an ideal sonar)
  /// would give a zero-width gate; 5 mm is the resolution of typical altimeters.
  double min_noise_std_m = 0.005;
  /// Bound on the second time derivative of the slant range [m/s^2], i.e. how far the true range
  /// can bend away from the straight-line trend. It widens the gate by the worst-case bending
  /// over the extrapolation; 0.3 covers +-5 deg pitch oscillations at 0.5 Hz at 2 m altitude.
  double max_range_accel_mps2 = 0.3;
  /// No accepted sample for this long [s] (dropouts, outliers or missing messages): the trend is
  /// no longer trustworthy, the filter resets and re-acquires. 1 s = 10 samples at 10 Hz, so a
  /// single dropout or outlier never resets it; a sonar slower than acquire_samples + 1 samples
  /// per max_gap_s gets that many of its periods instead (SonarAltitudeFilter).
  double max_gap_s = 1.0;
  /// Consecutive valid samples that must agree (each within the gate of the line through the
  /// others) before the filter (re)acquires. 4 is the smallest number for which a line through
  /// the other 3 exposes an outlier at either end; it costs a decision delay of 3 samples after
  /// a reset (the held samples are then emitted together, in order).
  int acquire_samples = 4;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<SonarFilterOptions>& optionTable();
  /// Reads the options from a mapping (e.g. config/sonar.yaml or a `sonar_filter:` section).
  /// Missing keys keep their defaults; unknown keys and out-of-range values throw ConfigError
  /// naming the key.
  static SonarFilterOptions fromReader(const ConfigReader& reader);
  /// Checks every value; `reader` only names the source in the error. Throws ConfigError.
  void validate(const ConfigReader& reader) const;
  /// The options as YAML (same keys as fromReader reads), for logging.
  std::string toYaml() const;
};

}  // namespace vims
