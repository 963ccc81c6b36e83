#pragma once
/// @file magnetic_front_end.h
/// @brief The magnetometer front end as vims_offline and vims_magnetometer_node run it: the
/// SignatureExtractor, preceded by a search for the coil's frequency when the sequence leaves it
/// open (contract v2: coil_frequency_hz null or absent).
///
/// While searching, the magnetometer and IMU samples are buffered; every time the buffer spans
/// coil_search.window_s the spectrum is searched (coil_frequency_search.h). Found: the extractor
/// is built for that frequency and the buffered samples are fed to it in time order, so the first
/// windows are not lost (their outputs come out with the call that found the line). Not found
/// (no coil in reach yet): the older half of the buffer is dropped and the search repeats when
/// the buffer is full again; the magnetic outputs wait, and loop closing works visually. The
/// search finds one coil (the strongest line).
///
/// Several coils (contract v2: a list of frequencies): one SignatureExtractor per coil, each fed
/// every sample, whose windows carry the coil's index (SignatureWindow::coil). Each measures its
/// coil with a Hann-windowed DTFT at that coil's frequency, where the other coils' lines leak
/// nothing measurable when they are a few bins away (a warning names coils closer than the SNR's
/// noise bins, whose lines raise the noise floor and lower the SNR). The geomagnetic output comes
/// from the first coil's extractor: its moving average spans whole periods of the first coil, and
/// attenuates another coil's line at f by ~1 / (pi f T) (T its length, ~1 s): a ripple that the
/// pose graph's geomagnetic gate rejects near that coil, where it matters.

#include <deque>
#include <memory>
#include <vector>

#include "vims_magnetometer/signature_extractor.h"

namespace vims {

class MagneticFrontEnd {
 public:
  /// Throws ConfigError if the options do not suit the sensor. `gravity` is imu.gravity.
  MagneticFrontEnd(const MagnetometerOptions& options, const MagnetometerCalibration& calibration, double gravity,
                   LoggerPtr logger = Logger::nullLogger());
  ~MagneticFrontEnd();

  void feedImu(const ImuSample& sample);
  /// Appends finished windows to `signatures` and geomagnetic outputs to `geomagnetic` (either
  /// may be null).
  void feedMag(const MagSample& sample, std::vector<SignatureWindow>* signatures,
               std::vector<GeomagneticSample>* geomagnetic);

  /// The (first) coil's frequency in use [Hz]: the sequence's, or the one found; 0 while searching.
  double coilFrequency() const;
  /// Coils measured (0 while searching).
  int coils() const { return static_cast<int>(extractors_.size()); }
  /// The first coil's extractor's counters, with `windows` and `valid_windows` summed over every
  /// coil (samples still buffered for the search are not counted yet; samples dropped by a search
  /// that found nothing are in `mag_samples` only).
  SignatureExtractorStats stats() const;
  /// Spectrum searches run so far (0 when the sequence states the frequency).
  int searches() const { return searches_; }

 private:
  void search(std::vector<SignatureWindow>* signatures, std::vector<GeomagneticSample>* geomagnetic);

  MagnetometerOptions options_;
  MagnetometerCalibration calibration_;
  double gravity_;
  LoggerPtr logger_;
  /// One per coil, in the sequence's order; empty while searching.
  std::vector<std::unique_ptr<SignatureExtractor>> extractors_;
  std::deque<MagSample> mag_buffer_;
  std::deque<ImuSample> imu_buffer_;
  long dropped_samples_ = 0;
  int searches_ = 0;
};

}  // namespace vims
