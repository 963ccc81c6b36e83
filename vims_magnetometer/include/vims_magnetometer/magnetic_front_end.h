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
/// the buffer is full again; the magnetic outputs wait, and loop closing works visually.

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

  /// The coil frequency in use [Hz]: the sequence's, or the one found; 0 while searching.
  double coilFrequency() const;
  /// The extractor's counters (samples still buffered for the search are not counted yet;
  /// samples dropped by a search that found nothing are in `mag_samples` only).
  SignatureExtractorStats stats() const;
  /// Spectrum searches run so far (0 when the sequence states the frequency).
  int searches() const { return searches_; }

 private:
  void search(std::vector<SignatureWindow>* signatures, std::vector<GeomagneticSample>* geomagnetic);

  MagnetometerOptions options_;
  MagnetometerCalibration calibration_;
  double gravity_;
  LoggerPtr logger_;
  std::unique_ptr<SignatureExtractor> extractor_;
  std::deque<MagSample> mag_buffer_;
  std::deque<ImuSample> imu_buffer_;
  long dropped_samples_ = 0;
  int searches_ = 0;
};

}  // namespace vims
