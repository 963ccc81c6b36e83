#pragma once
/// @file signature_extractor.h
/// @brief Magnetic signature extraction from the 1000 Hz magnetometer (paper, "Measurement
/// Preprocessing" and "Magnetic Submaps").
///
/// Pipeline, per magnetometer sample (mag frame m, uniformly sampled at rate_hz):
///  1. Geomagnetic separation. A centred moving average over N samples, N spanning a whole
///     number of coil periods (chooseMovingAverage), so the coil's sine averages out and the
///     mean is the geomagnetic field B_e (it changes only slowly, as the vehicle turns). The
///     alternating field of the centre sample is b_m = B_m - mean. Both are delayed by N/2.
///     R_b_m * mean is the low-passed geomagnetic field in the body frame: it is output every
///     geomagnetic_output_period_s (for the pose graph's yaw factors) and steers the heading of
///     the attitude filter.
///  2. Rotation to ENU, sample by sample: b_w = R_w_b(t) * R_b_m * b_m with the attitude filter's
///     q_w_b at the sample's own time (attitude_filter.h explains why an AHRS and not the VIO).
///  3. Spectrum. Every hop_s, over the last window_s of b_w: a Hann-weighted DTFT at exactly the
///     coil frequency (Goertzel, so there is no bin-scalloping however f and window_s relate), per
///     ENU axis. The amplitude of axis i is 2 Re(X_i conj(X_d)) / (|X_d| sum(w)), d = the dominant
///     axis: the in-phase part relative to the dominant axis, whose sign says in phase (+) or in
///     antiphase (-). A dipole's field oscillates along one fixed direction, so this is the peak
///     amplitude vector up to a global sign, fixed by making the dominant component positive.
///     SNR = sum_i |X_i(f)|^2 / mean over neighbouring frequencies f +- k/window_s
///     (k = snr_inner_bins..snr_outer_bins) of sum_i |X_i|^2.
///  4. Validity. A window is invalid (still output) when one of its samples is missing (gap),
///     was non-finite, came from a moving average that contained such a sample, had no attitude,
///     or when SNR < min_snr.
///
/// Time. A stamp going backwards by more than half a sample resets the pipeline (a bag loop);
/// a repeated stamp is dropped; missing samples up to max_fill_gap_s are filled with invalid
/// slots, a longer gap restarts the pipeline. Slots are counted from the stamp differences, so
/// a clock that runs slightly off rate_hz does not accumulate an error.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "vims_common/log.h"
#include "vims_common/magnetic_signature.h"
#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"
#include "vims_magnetometer/attitude_filter.h"
#include "vims_magnetometer/magnetometer_options.h"

namespace vims {

struct MovingAverageLength {
  int periods = 0;        ///< coil periods covered
  int samples = 0;        ///< N
  double residual = 0.0;  ///< |periods * rate / f - N| [samples]: 0 when exact
};
/// The smallest number of coil periods in [min_periods, 4 min_periods] whose length is closest
/// to a whole number of samples (first exact match wins).
MovingAverageLength chooseMovingAverage(double rate_hz, double coil_frequency_hz, int min_periods);

struct SignatureExtractorStats {
  long mag_samples = 0;
  long duplicates = 0;    ///< dropped repeated stamps
  long filled_slots = 0;  ///< missing samples filled as invalid
  long nonfinite = 0;
  long resets = 0;  ///< clock backwards or gaps longer than max_fill_gap_s
  long windows = 0;
  long valid_windows = 0;
  double frequency_hz = 0.0;  ///< the coil frequency of the latest window (tracked)
};

class SignatureExtractor {
 public:
  /// Throws ConfigError if the options do not suit the sensor. `gravity` is imu.gravity. The
  /// extractor measures the coil at calibration.coil_frequency_hz; its windows carry `coil` (the
  /// coil's index in the sequence's list).
  SignatureExtractor(const MagnetometerOptions& options, const MagnetometerCalibration& calibration, double gravity,
                     LoggerPtr logger = Logger::nullLogger(), int coil = 0);

  void feedImu(const ImuSample& sample) { attitude_.feedImu(sample); }
  /// Appends finished windows to `signatures` and geomagnetic outputs to `geomagnetic` (either
  /// may be null).
  void feedMag(const MagSample& sample, std::vector<SignatureWindow>* signatures,
               std::vector<GeomagneticSample>* geomagnetic);
  /// Restarts the magnetometer pipeline (the attitude filter keeps its state).
  void reset();

  const MovingAverageLength& movingAverage() const { return moving_average_; }
  int windowSamples() const { return window_samples_; }
  int hopSamples() const { return hop_samples_; }
  const AttitudeFilter& attitude() const { return attitude_; }
  const SignatureExtractorStats& stats() const { return stats_; }
  const MagnetometerOptions& options() const { return options_; }

 private:
  struct RawSlot {
    double t;
    Eigen::Vector3d B_m;
    unsigned flags;
  };
  struct AltSlot {
    double t;
    Eigen::Vector3d b_w;      ///< alternating field in ENU (zero when flagged)
    Eigen::Vector3d B_geo_b;  ///< geomagnetic field in the body frame (zero when flagged)
    unsigned flags;
  };

  void pushRaw(double t, const Eigen::Vector3d& B_m, unsigned flags, std::vector<GeomagneticSample>* geomagnetic,
               std::vector<SignatureWindow>* signatures);
  void pushAlt(const AltSlot& slot, std::vector<SignatureWindow>* signatures);
  /// The window ending at the newest slot; `peak_offset_hz` receives the offset of the spectral
  /// peak from the current frequency (0 when not tracking).
  SignatureWindow computeWindow(double* peak_offset_hz) const;
  /// Moves the frequency towards a valid window's peak (MagnetometerOptions::frequency_tracking_*).
  void trackFrequency(double peak_offset_hz);

  MagnetometerOptions options_;
  MagnetometerCalibration calibration_;
  Eigen::Matrix3d R_b_m_;
  LoggerPtr logger_;
  int coil_;
  AttitudeFilter attitude_;
  MovingAverageLength moving_average_;
  int window_samples_;
  int hop_samples_;
  std::vector<double> hann_;
  double hann_sum_ = 0.0;
  double nominal_frequency_hz_;  ///< stated in the sequence YAML (or found)
  double frequency_hz_;          ///< tracked coil frequency
  /// The frequency the moving average spans whole periods of; rebuilt (a restart of the
  /// magnetometer pipeline) once the tracked one is too far from it.
  double moving_average_frequency_hz_;
  bool rebuild_moving_average_ = false;
  /// Offsets [Hz] from frequency_hz_ of the evaluated frequencies: [0] = 0 (the coil), then
  /// the noise neighbours, then (tracking) the two probes half a bin either side.
  std::vector<double> offsets_;
  size_t noise_bins_ = 0;

  // Moving average state (ring of the last N raw slots).
  std::vector<RawSlot> raw_;
  long raw_count_ = 0;
  Eigen::Vector3d raw_sum_ = Eigen::Vector3d::Zero();
  int raw_gap_count_ = 0;
  int raw_nonfinite_count_ = 0;
  // Spectral window state (ring of the last window_samples alternating slots).
  std::vector<AltSlot> alt_;
  long alt_count_ = 0;

  bool have_last_t_ = false;
  double last_t_ = 0.0;
  bool have_geomagnetic_output_ = false;
  double last_geomagnetic_output_t_ = 0.0;
  SignatureExtractorStats stats_;
};

}  // namespace vims
