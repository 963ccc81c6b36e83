#include "vims_magnetometer/magnetometer_options.h"

#include <cmath>
#include <sstream>

namespace vims {

AttitudeFilterOptions AttitudeFilterOptions::fromReader(const ConfigReader& reader) {
  reader.rejectUnknownKeys({"tilt_time_constant_s", "heading_time_constant_s", "gyro_bias_time_constant_s",
                            "accel_gate_mps2", "max_imu_gap_s"});
  AttitudeFilterOptions o;
  o.tilt_time_constant_s = reader.get<double>("tilt_time_constant_s", o.tilt_time_constant_s);
  o.heading_time_constant_s = reader.get<double>("heading_time_constant_s", o.heading_time_constant_s);
  o.gyro_bias_time_constant_s = reader.get<double>("gyro_bias_time_constant_s", o.gyro_bias_time_constant_s);
  o.accel_gate_mps2 = reader.get<double>("accel_gate_mps2", o.accel_gate_mps2);
  o.max_imu_gap_s = reader.get<double>("max_imu_gap_s", o.max_imu_gap_s);
  o.validate(reader);
  return o;
}

void AttitudeFilterOptions::validate(const ConfigReader& reader) const {
  requireInRange(reader, "tilt_time_constant_s", tilt_time_constant_s, 0.01, 1000.0);
  requireInRange(reader, "heading_time_constant_s", heading_time_constant_s, 0.01, 1000.0);
  requireInRange(reader, "gyro_bias_time_constant_s", gyro_bias_time_constant_s, 0.1, 1e5);
  requirePositive(reader, "accel_gate_mps2", accel_gate_mps2);
  requireInRange(reader, "max_imu_gap_s", max_imu_gap_s, 1e-4, 10.0);
}

std::string AttitudeFilterOptions::toYaml(const std::string& indent) const {
  std::ostringstream os;
  os << indent << "tilt_time_constant_s: " << tilt_time_constant_s << "\n"
     << indent << "heading_time_constant_s: " << heading_time_constant_s << "\n"
     << indent << "gyro_bias_time_constant_s: " << gyro_bias_time_constant_s << "\n"
     << indent << "accel_gate_mps2: " << accel_gate_mps2 << "\n"
     << indent << "max_imu_gap_s: " << max_imu_gap_s << "\n";
  return os.str();
}

MagnetometerOptions MagnetometerOptions::fromReader(const ConfigReader& reader) {
  reader.rejectUnknownKeys({"window_s", "hop_s", "min_snr", "snr_inner_bins", "snr_outer_bins",
                            "geomagnetic_min_periods", "geomagnetic_output_period_s", "max_fill_gap_s", "attitude"});
  MagnetometerOptions o;
  o.window_s = reader.get<double>("window_s", o.window_s);
  o.hop_s = reader.get<double>("hop_s", o.hop_s);
  o.min_snr = reader.get<double>("min_snr", o.min_snr);
  o.snr_inner_bins = reader.get<int>("snr_inner_bins", o.snr_inner_bins);
  o.snr_outer_bins = reader.get<int>("snr_outer_bins", o.snr_outer_bins);
  o.geomagnetic_min_periods = reader.get<int>("geomagnetic_min_periods", o.geomagnetic_min_periods);
  o.geomagnetic_output_period_s = reader.get<double>("geomagnetic_output_period_s", o.geomagnetic_output_period_s);
  o.max_fill_gap_s = reader.get<double>("max_fill_gap_s", o.max_fill_gap_s);
  o.attitude = AttitudeFilterOptions::fromReader(reader.childOrEmpty("attitude"));
  o.validate(reader);
  return o;
}

void MagnetometerOptions::validate(const ConfigReader& reader) const {
  requireInRange(reader, "window_s", window_s, 0.1, 60.0);
  requirePositive(reader, "hop_s", hop_s);
  if (hop_s > window_s) throw reader.error("hop_s", "must not exceed window_s (windows would leave samples out)");
  requireNonNegative(reader, "min_snr", min_snr);
  if (snr_inner_bins < 2) {
    // Closer bins sit in the Hann main lobe and would measure the coil, not the noise.
    throw reader.error("snr_inner_bins", "must be >= 2, got " + std::to_string(snr_inner_bins));
  }
  if (snr_outer_bins < snr_inner_bins || snr_outer_bins > 100) {
    throw reader.error("snr_outer_bins", "must be in [snr_inner_bins, 100], got " + std::to_string(snr_outer_bins));
  }
  if (geomagnetic_min_periods < 1 || geomagnetic_min_periods > 1000) {
    throw reader.error("geomagnetic_min_periods",
                       "must be in [1, 1000], got " + std::to_string(geomagnetic_min_periods));
  }
  requirePositive(reader, "geomagnetic_output_period_s", geomagnetic_output_period_s);
  requireNonNegative(reader, "max_fill_gap_s", max_fill_gap_s);
  attitude.validate(reader.childOrEmpty("attitude"));
}

void MagnetometerOptions::validateFor(const MagnetometerCalibration& cal, const ConfigReader& reader) const {
  validate(reader);
  const double periods = window_s * cal.coil_frequency_hz;
  if (periods < 4.0) {
    throw reader.error("window_s", "holds only " + std::to_string(periods) +
                                       " coil periods; at least 4 are needed to resolve the coil frequency");
  }
  if (std::lround(hop_s * cal.rate_hz) < 1) throw reader.error("hop_s", "is shorter than one sample");
  const double bin = 1.0 / window_s;
  if (cal.coil_frequency_hz - snr_outer_bins * bin <= 0.0 ||
      cal.coil_frequency_hz + snr_outer_bins * bin >= 0.5 * cal.rate_hz) {
    throw reader.error("snr_outer_bins", "puts neighbouring bins outside (0, Nyquist) for a " +
                                             std::to_string(cal.coil_frequency_hz) + " Hz coil");
  }
  const double ma_s = geomagnetic_min_periods / cal.coil_frequency_hz;
  if (ma_s > 30.0) {
    throw reader.error("geomagnetic_min_periods", "gives a moving average longer than 30 s");
  }
}

std::string MagnetometerOptions::toYaml() const {
  std::ostringstream os;
  os << "window_s: " << window_s << "\n"
     << "hop_s: " << hop_s << "\n"
     << "min_snr: " << min_snr << "\n"
     << "snr_inner_bins: " << snr_inner_bins << "\n"
     << "snr_outer_bins: " << snr_outer_bins << "\n"
     << "geomagnetic_min_periods: " << geomagnetic_min_periods << "\n"
     << "geomagnetic_output_period_s: " << geomagnetic_output_period_s << "\n"
     << "max_fill_gap_s: " << max_fill_gap_s << "\n"
     << "attitude:\n"
     << attitude.toYaml("  ");
  return os.str();
}

}  // namespace vims
