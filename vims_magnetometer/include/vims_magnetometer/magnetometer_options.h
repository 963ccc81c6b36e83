#pragma once
/// @file magnetometer_options.h
/// @brief Algorithm parameters of the magnetic signature extractor and its attitude filter.
///
/// The sensor's calibration (rate, noise, coil frequency, declination, T_b_m) comes from the
/// sequence YAML (MagnetometerCalibration), never from here. Defaults and the reason for each are
/// repeated in config/magnetometer.yaml.

#include <string>

#include "vims_common/config_reader.h"
#include "vims_common/sequence_config.h"
#include "vims_magnetometer/iron_calibration.h"

namespace vims {

template <typename Options>
class OptionTable;

/// The small AHRS that rotates the alternating field into ENU (see attitude_filter.h).
struct AttitudeFilterOptions {
  /// Time constant [s] with which roll and pitch are pulled towards the accelerometer's gravity
  /// direction. The gyro carries the attitude over shorter times; 2 s averages the accelerometer
  /// noise and the AUV's brief surge/heave accelerations down to well below 0.1 deg.
  double tilt_time_constant_s = 2.0;
  /// Time constant [s] with which the heading is pulled towards the low-passed geomagnetic field.
  /// It must be long against the moving average's 0.5 s delay (loop stability) and short against
  /// gyro-bias drift; 5 s does both.
  double heading_time_constant_s = 5.0;
  /// Time constant [s] of the gyro-bias integrator (the "I" of a Mahony-type PI filter): the
  /// corrections above are integrated into a bias estimate, so a constant gyro bias leaves no
  /// steady attitude error (a proportional-only filter would keep bias * time constant, e.g.
  /// 0.6 deg for 0.002 rad/s over 5 s). 20 s makes the heading loop critically damped with the
  /// 5 s heading constant (damping = sqrt(20 / 5) / 2 = 1) and the tilt loop overdamped.
  double gyro_bias_time_constant_s = 20.0;
  /// Tilt correction is skipped while | |specific force| - g | exceeds this [m/s^2]: the vehicle
  /// is then accelerating and the accelerometer does not show gravity alone.
  double accel_gate_mps2 = 0.5;
  /// A longer interval between IMU samples [s] cannot be bridged by gyro integration: the
  /// attitude is re-initialised from gravity and the geomagnetic field. 0.1 s = 20 samples at
  /// the contract's 200 Hz.
  double max_imu_gap_s = 0.1;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<AttitudeFilterOptions>& optionTable();
  static AttitudeFilterOptions fromReader(const ConfigReader& reader);
  void validate(const ConfigReader& reader) const;
  std::string toYaml() const;
};

/// The search for the coil's frequency when the sequence leaves it open (contract v2:
/// coil_frequency_hz null or absent; coil_frequency_search.h).
struct CoilSearchOptions {
  /// Magnetometer data [s] whose spectrum is searched; the signatures start once it is found
  /// (the buffered data are then processed). 10 s resolves 0.1 Hz bins and holds 110 periods
  /// of an 11 Hz coil, enough to place the peak to a few mHz.
  double window_s = 10.0;
  /// The band searched [Hz]: above the vehicle's own motion (turns modulate the geomagnetic
  /// field below ~1 Hz), up to this fraction of the Nyquist frequency (the anti-alias roll-off).
  double min_frequency_hz = 2.0;
  double max_fraction_of_nyquist = 0.9;
  /// A line counts as the coil when its power is at least this many times the median power within
  /// 1 Hz of it. Noise alone stays below ~10x (6.4x in the unit test's 10 s of 1000 Hz data), so 100 (20 dB)
  /// does not take noise for a coil; data without a coil in reach are searched again later.
  double min_peak_to_median = 100.0;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<CoilSearchOptions>& optionTable();
};

/// The keys of `iron_correction` (hard_iron_t, soft_iron_inverse) as MagnetometerOptions writes
/// and reads them: what vims_mag_calib puts in its file.
std::string ironCorrectionYaml(const IronCorrection& correction);

struct MagnetometerOptions {
  /// Length of one spectral window [s]. The paper's high-rate magnetometer reaches good
  /// signatures with 2 s of data (22 coil periods at 11 Hz, bin spacing 0.5 Hz).
  double window_s = 2.0;
  /// Interval between window starts [s]; the paper's 0.4 s output interval.
  double hop_s = 0.4;
  /// Windows whose coil-bin power is less than this many times the mean power of the
  /// neighbouring bins are invalid. White noise moves the amplitude by about 1/sqrt(2 SNR) of
  /// itself, so 100 (20 dB) keeps that below ~7 %: a weaker window says little about the place.
  /// (With the contract's 5 nT noise a 2 s window reaches SNR 100 at ~5 nT of coil amplitude.)
  double min_snr = 100.0;
  /// Neighbouring bins for the noise estimate: offsets inner..outer (both signs) in units of
  /// 1/window_s from the coil frequency. The Hann window's main lobe spans +-2 bins, so 3..6
  /// measures the noise floor just outside the coil's own leakage.
  int snr_inner_bins = 3;
  int snr_outer_bins = 6;
  /// The geomagnetic moving average spans the smallest whole number of coil periods >= this
  /// (searching up to 4x) that is closest to a whole number of samples, so the coil sine
  /// averages out. 10 periods ~ 0.9 s at 11 Hz; 1000 Hz / 11 Hz picks 11 periods = 1000 samples.
  int geomagnetic_min_periods = 10;
  /// Interval [s] at which the low-passed geomagnetic vector is output (for the pose graph's
  /// yaw factors, which need one per keyframe at most; 10 Hz covers any keyframe rate).
  double geomagnetic_output_period_s = 0.1;
  /// Missing samples spanning up to this long [s] are filled with invalid slots so that every
  /// window touching the gap is still published (valid = false); a longer gap restarts the
  /// pipeline. 2 s = one window.
  double max_fill_gap_s = 2.0;
  /// A free-running coil oscillator drifts (temperature, battery): each valid window 10x above
  /// min_snr measures the offset of the spectral peak from the current coil frequency (the log
  /// power half a bin either side) and moves the frequency by hop_s / this of it [s]. 10 s: a 0.1 Hz drift over
  /// ten minutes lags by 2 mHz, where a 2 s window loses 0.002 % of the amplitude, while single
  /// windows' noise averages over 25 of them. 0: the frequency stays as stated (or found).
  double frequency_tracking_time_constant_s = 10.0;
  /// The tracked frequency stays within this [Hz] of the stated (or found) one, so no other line
  /// (a thruster's, another coil's) can pull it further away.
  double frequency_tracking_max_offset_hz = 0.5;
  AttitudeFilterOptions attitude;
  CoilSearchOptions coil_search;
  /// The vehicle's hard and soft iron, taken out of every sample first (iron_calibration.h):
  /// keys `iron_correction.hard_iron_t` [T, mag frame] and `iron_correction.soft_iron_inverse`
  /// (3x3 row-major), as vims_mag_calib writes them. The default (none) suits a magnetometer that is
  /// calibrated before its data reach VIMS, as the sensor contract states.
  IronCorrection iron_correction;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<MagnetometerOptions>& optionTable();
  /// Reads a mapping (config/magnetometer.yaml or a section of it); missing keys keep their
  /// defaults; the AHRS options are in the sub-mapping `attitude`. Unknown keys and out-of-range
  /// values throw ConfigError naming the key.
  static MagnetometerOptions fromReader(const ConfigReader& reader);
  void validate(const ConfigReader& reader) const;
  /// Checks the options against the sensor (window long enough, neighbouring bins inside
  /// (0, Nyquist), ...). Throws ConfigError naming the offending option key.
  void validateFor(const MagnetometerCalibration& calibration, const ConfigReader& reader) const;
  std::string toYaml() const;
};

}  // namespace vims
