#include "vims_magnetometer/magnetic_front_end.h"

#include <cmath>

#include "vims_magnetometer/coil_frequency_search.h"

namespace vims {
namespace {
constexpr const char* kComponent = "mag_front_end";
}  // namespace

MagneticFrontEnd::MagneticFrontEnd(const MagnetometerOptions& options, const MagnetometerCalibration& calibration,
                                   double gravity, LoggerPtr logger)
    : options_(options),
      calibration_(calibration),
      gravity_(gravity),
      logger_(logger ? std::move(logger) : Logger::nullLogger()) {
  options_.validateFor(calibration_, ConfigReader::fromString("", "magnetometer options"));
  if (!options_.iron_correction.isIdentity()) {
    const IronCorrection& c = options_.iron_correction;
    logger_->info(kComponent, VIMS_STR("iron correction: hard iron " << c.hard_iron_t.transpose() * 1e6
                                                                     << " uT, soft-iron inverse diagonal "
                                                                     << c.soft_iron_inverse.diagonal().transpose()));
  }
  if (calibration_.coilFrequencyKnown()) {
    std::vector<double> frequencies{calibration_.coil_frequency_hz};
    frequencies.insert(frequencies.end(), calibration_.other_coil_frequencies_hz.begin(),
                       calibration_.other_coil_frequencies_hz.end());
    // Another coil's main lobe inside a coil's noise bins raises that coil's noise floor.
    const double min_separation_hz = (options_.snr_outer_bins + 2) / options_.window_s;
    for (size_t i = 0; i < frequencies.size(); ++i) {
      MagnetometerCalibration coil = calibration_;
      coil.coil_frequency_hz = frequencies[i];
      coil.other_coil_frequencies_hz.clear();
      extractors_.push_back(
          std::make_unique<SignatureExtractor>(options_, coil, gravity_, logger_, static_cast<int>(i)));
      for (size_t j = 0; j < i; ++j)
        if (std::abs(frequencies[i] - frequencies[j]) < min_separation_hz)
          logger_->warn(kComponent, VIMS_STR("coils " << j << " (" << frequencies[j] << " Hz) and " << i << " ("
                                                      << frequencies[i] << " Hz) are closer than " << min_separation_hz
                                                      << " Hz: each one's line raises the other's noise floor, so "
                                                         "their SNR is lower"));
    }
    if (frequencies.size() > 1)
      logger_->info(kComponent, VIMS_STR("measuring " << frequencies.size() << " coils, one signature per coil"));
  } else {
    logger_->info(kComponent, VIMS_STR("the sequence leaves the coil frequency open: searching "
                                       << options_.coil_search.window_s << " s of data for it"));
  }
}

MagneticFrontEnd::~MagneticFrontEnd() = default;

void MagneticFrontEnd::feedImu(const ImuSample& sample) {
  if (!extractors_.empty()) {
    for (const auto& extractor : extractors_) extractor->feedImu(sample);
  } else {
    imu_buffer_.push_back(sample);
  }
}

void MagneticFrontEnd::feedMag(const MagSample& raw, std::vector<SignatureWindow>* signatures,
                               std::vector<GeomagneticSample>* geomagnetic) {
  // The iron correction comes first: the geomagnetic field and the coil's lines both pass through
  // the vehicle's iron (a non-finite sample stays non-finite, and the extractor marks it).
  MagSample sample = raw;
  sample.field = options_.iron_correction.apply(raw.field);
  if (!extractors_.empty()) {
    extractors_.front()->feedMag(sample, signatures, geomagnetic);  // the geomagnetic source
    for (size_t i = 1; i < extractors_.size(); ++i) extractors_[i]->feedMag(sample, signatures, nullptr);
    return;
  }
  if (!mag_buffer_.empty() && !(sample.t >= mag_buffer_.back().t)) {
    // A clock going backwards (a bag loop) or a non-finite stamp: start the search afresh.
    dropped_samples_ += static_cast<long>(mag_buffer_.size());
    mag_buffer_.clear();
    imu_buffer_.clear();
    if (!std::isfinite(sample.t)) return;
  }
  mag_buffer_.push_back(sample);
  if (mag_buffer_.back().t - mag_buffer_.front().t >= options_.coil_search.window_s) search(signatures, geomagnetic);
}

void MagneticFrontEnd::search(std::vector<SignatureWindow>* signatures, std::vector<GeomagneticSample>* geomagnetic) {
  ++searches_;
  std::vector<MagSample> finite;
  finite.reserve(mag_buffer_.size());
  for (const MagSample& s : mag_buffer_)
    if (s.field.allFinite()) finite.push_back(s);
  const CoilLine line = findCoilLine(finite, calibration_.rate_hz, options_.coil_search);
  if (!line.found) {
    logger_->info(kComponent,
                  VIMS_STR("no coil line yet in " << options_.coil_search.window_s << " s of data (strongest at "
                                                  << line.frequency_hz << " Hz, " << line.peak_to_median
                                                  << "x the power around it); searching on"));
    const double keep_from = mag_buffer_.back().t - 0.5 * options_.coil_search.window_s;
    while (!mag_buffer_.empty() && mag_buffer_.front().t < keep_from) {
      mag_buffer_.pop_front();
      ++dropped_samples_;
    }
    while (!imu_buffer_.empty() && imu_buffer_.front().t < keep_from) imu_buffer_.pop_front();
    return;
  }
  MagnetometerCalibration found = calibration_;
  found.coil_frequency_hz = line.frequency_hz;
  try {
    extractors_.push_back(std::make_unique<SignatureExtractor>(options_, found, gravity_, logger_));
  } catch (const ConfigError& e) {
    // The options do not suit this frequency (e.g. too few periods in a window): a line that
    // low or high is not a coil VIMS can use; keep searching.
    logger_->warn(kComponent, VIMS_STR("a line at " << line.frequency_hz << " Hz was found but " << e.what()));
    mag_buffer_.clear();
    imu_buffer_.clear();
    return;
  }
  calibration_ = found;
  logger_->info(kComponent, VIMS_STR("coil frequency found: " << line.frequency_hz << " Hz (" << line.peak_to_median
                                                              << "x the power around it)"));
  // Replay the buffered samples in time order (IMU first at equal stamps, as a bag would).
  SignatureExtractor& extractor = *extractors_.front();
  auto imu = imu_buffer_.begin();
  for (const MagSample& m : mag_buffer_) {
    for (; imu != imu_buffer_.end() && imu->t <= m.t; ++imu) extractor.feedImu(*imu);
    extractor.feedMag(m, signatures, geomagnetic);
  }
  for (; imu != imu_buffer_.end(); ++imu) extractor.feedImu(*imu);
  mag_buffer_.clear();
  imu_buffer_.clear();
}

double MagneticFrontEnd::coilFrequency() const { return extractors_.empty() ? 0.0 : calibration_.coil_frequency_hz; }

SignatureExtractorStats MagneticFrontEnd::stats() const {
  SignatureExtractorStats s = extractors_.empty() ? SignatureExtractorStats{} : extractors_.front()->stats();
  for (size_t i = 1; i < extractors_.size(); ++i) {
    s.windows += extractors_[i]->stats().windows;
    s.valid_windows += extractors_[i]->stats().valid_windows;
  }
  s.mag_samples += dropped_samples_;
  return s;
}

}  // namespace vims
