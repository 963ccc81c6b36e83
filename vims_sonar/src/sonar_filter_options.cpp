#include "vims_sonar/sonar_filter_options.h"

#include <sstream>

namespace vims {

SonarFilterOptions SonarFilterOptions::fromReader(const ConfigReader& reader) {
  reader.rejectUnknownKeys(
      {"window_size", "gate_sigma", "min_noise_std_m", "max_range_accel_mps2", "max_gap_s", "acquire_samples"});
  SonarFilterOptions o;
  o.window_size = reader.get<int>("window_size", o.window_size);
  o.gate_sigma = reader.get<double>("gate_sigma", o.gate_sigma);
  o.min_noise_std_m = reader.get<double>("min_noise_std_m", o.min_noise_std_m);
  o.max_range_accel_mps2 = reader.get<double>("max_range_accel_mps2", o.max_range_accel_mps2);
  o.max_gap_s = reader.get<double>("max_gap_s", o.max_gap_s);
  o.acquire_samples = reader.get<int>("acquire_samples", o.acquire_samples);
  o.validate(reader);
  return o;
}

void SonarFilterOptions::validate(const ConfigReader& reader) const {
  // A line needs 2 points and the leave-one-out check of acquisition a third.
  if (acquire_samples < 3 || acquire_samples > 50) {
    throw reader.error("acquire_samples", "must be in [3, 50], got " + std::to_string(acquire_samples));
  }
  if (window_size < acquire_samples || window_size > 200) {
    throw reader.error("window_size", "must be in [acquire_samples (" + std::to_string(acquire_samples) +
                                          "), 200], got " + std::to_string(window_size));
  }
  requireInRange(reader, "gate_sigma", gate_sigma, 1.0, 20.0);
  requirePositive(reader, "min_noise_std_m", min_noise_std_m);
  requireNonNegative(reader, "max_range_accel_mps2", max_range_accel_mps2);
  requirePositive(reader, "max_gap_s", max_gap_s);
}

std::string SonarFilterOptions::toYaml() const {
  std::ostringstream os;
  os << "window_size: " << window_size << "\n"
     << "gate_sigma: " << gate_sigma << "\n"
     << "min_noise_std_m: " << min_noise_std_m << "\n"
     << "max_range_accel_mps2: " << max_range_accel_mps2 << "\n"
     << "max_gap_s: " << max_gap_s << "\n"
     << "acquire_samples: " << acquire_samples << "\n";
  return os.str();
}

}  // namespace vims
