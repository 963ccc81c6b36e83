#include "vims_magnetometer/magnetometer_options.h"

#include <Eigen/SVD>
#include <cmath>

#include "vims_common/option_table.h"

namespace vims {

const OptionTable<AttitudeFilterOptions>& AttitudeFilterOptions::optionTable() {
  using O = AttitudeFilterOptions;
  static const auto table =
      OptionTable<O>()
          .number("tilt_time_constant_s", &O::tilt_time_constant_s, Bounds::closed(0.01, 1000.0))
          .number("heading_time_constant_s", &O::heading_time_constant_s, Bounds::closed(0.01, 1000.0))
          .number("gyro_bias_time_constant_s", &O::gyro_bias_time_constant_s, Bounds::closed(0.1, 1e5))
          .number("accel_gate_mps2", &O::accel_gate_mps2, Bounds::positive())
          .number("max_imu_gap_s", &O::max_imu_gap_s, Bounds::closed(1e-4, 10.0));
  return table;
}

AttitudeFilterOptions AttitudeFilterOptions::fromReader(const ConfigReader& reader) {
  return readOptions<AttitudeFilterOptions>(reader);
}

void AttitudeFilterOptions::validate(const ConfigReader& reader) const {
  if (const auto v = optionTable().firstViolation(*this)) throw reader.error(v->key, v->message);
}

std::string AttitudeFilterOptions::toYaml() const { return optionTable().toYaml(*this); }

const OptionTable<CoilSearchOptions>& CoilSearchOptions::optionTable() {
  using O = CoilSearchOptions;
  static const auto table =
      OptionTable<O>()
          .number("window_s", &O::window_s, Bounds::closed(1.0, 120.0))
          .number("min_frequency_hz", &O::min_frequency_hz, Bounds::closed(0.1, 1000.0))
          .number("max_fraction_of_nyquist", &O::max_fraction_of_nyquist, Bounds::closed(0.1, 1.0))
          .number("min_peak_to_median", &O::min_peak_to_median, Bounds::closed(2.0, 1e9));
  return table;
}

namespace {

std::string vectorYaml(const double* v, int n) {
  std::string out = "[";
  for (int i = 0; i < n; ++i) out += (i ? ", " : "") + formatOptionNumber(v[i]);
  return out + "]";
}

const OptionTable<IronCorrection>& ironCorrectionTable() {
  using O = IronCorrection;
  static const auto table =
      OptionTable<O>()
          .custom(
              "hard_iron_t",
              [](const ConfigReader& r, const std::string& k, O& o) {
                const auto v = r.getVector(k, 3);
                for (double x : v)
                  if (!std::isfinite(x) || std::abs(x) > 1e-3)
                    throw r.error(k, "must be three finite numbers within 1 mT");
                o.hard_iron_t = Eigen::Vector3d(v[0], v[1], v[2]);
              },
              [](const O& o) { return vectorYaml(o.hard_iron_t.data(), 3); }, "three numbers [T], each within 1e-3")
          .custom(
              "soft_iron_inverse",
              [](const ConfigReader& r, const std::string& k, O& o) {
                const auto v = r.getVector(k, 9);
                Eigen::Matrix3d K;
                for (int i = 0; i < 9; ++i) K(i / 3, i % 3) = v[static_cast<size_t>(i)];
                // A vehicle's soft iron is a few percent: a matrix far from a rotation-free scale
                // near 1 is a mistyped or transposed file, not a calibration.
                const Eigen::Vector3d sv = K.jacobiSvd().singularValues();
                if (!K.allFinite() || sv.minCoeff() < 0.5 || sv.maxCoeff() > 2.0 || K.determinant() <= 0.0)
                  throw r.error(k, "must be a 3x3 row-major matrix with gains (singular values) in [0.5, 2]");
                o.soft_iron_inverse = K;
              },
              [](const O& o) {
                const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> K = o.soft_iron_inverse;
                return vectorYaml(K.data(), 9);
              },
              "nine numbers (3x3 row-major), gains in [0.5, 2]");
  return table;
}

}  // namespace

std::string ironCorrectionYaml(const IronCorrection& correction) { return ironCorrectionTable().toYaml(correction); }

const OptionTable<MagnetometerOptions>& MagnetometerOptions::optionTable() {
  using O = MagnetometerOptions;
  // snr_inner_bins >= 2: closer bins sit in the Hann main lobe and would measure the coil, not the noise.
  static const auto table =
      OptionTable<O>()
          .number("window_s", &O::window_s, Bounds::closed(0.1, 60.0))
          .number("hop_s", &O::hop_s, Bounds::positive())
          .number("min_snr", &O::min_snr, Bounds::nonNegative())
          .integer("snr_inner_bins", &O::snr_inner_bins, Bounds::closed(2, 100))
          .integer("snr_outer_bins", &O::snr_outer_bins, Bounds::closed(2, 100))
          .integer("geomagnetic_min_periods", &O::geomagnetic_min_periods, Bounds::closed(1, 1000))
          .number("geomagnetic_output_period_s", &O::geomagnetic_output_period_s, Bounds::positive())
          .number("max_fill_gap_s", &O::max_fill_gap_s, Bounds::nonNegative())
          .number("frequency_tracking_time_constant_s", &O::frequency_tracking_time_constant_s,
                  Bounds::closed(0.0, 1e5))
          .number("frequency_tracking_max_offset_hz", &O::frequency_tracking_max_offset_hz, Bounds::closed(0.0, 10.0))
          .section<AttitudeFilterOptions>("attitude", &O::attitude, AttitudeFilterOptions::optionTable())
          .section<CoilSearchOptions>("coil_search", &O::coil_search, CoilSearchOptions::optionTable())
          .section<IronCorrection>("iron_correction", &O::iron_correction, ironCorrectionTable())
          .rule([](const O& o) {
            return violationIf(o.hop_s > o.window_s, "hop_s",
                               "must not exceed window_s (windows would leave samples out)");
          })
          .rule([](const O& o) {
            return violationIf(o.snr_outer_bins < o.snr_inner_bins, "snr_outer_bins",
                               "must be >= snr_inner_bins, got " + std::to_string(o.snr_outer_bins));
          });
  return table;
}

MagnetometerOptions MagnetometerOptions::fromReader(const ConfigReader& reader) {
  return readOptions<MagnetometerOptions>(reader);
}

void MagnetometerOptions::validate(const ConfigReader& reader) const {
  if (const auto v = optionTable().firstViolation(*this)) throw reader.error(v->key, v->message);
}

void MagnetometerOptions::validateFor(const MagnetometerCalibration& cal, const ConfigReader& reader) const {
  validate(reader);
  if (!cal.coilFrequencyKnown()) {
    // The frequency is found from the data; these checks run again on the frequency found.
    if (coil_search.min_frequency_hz >= coil_search.max_fraction_of_nyquist * 0.5 * cal.rate_hz) {
      throw reader.error("coil_search.min_frequency_hz", "leaves no band below the Nyquist frequency to search");
    }
    return;
  }
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
  const double tracked = frequency_tracking_time_constant_s > 0.0 ? frequency_tracking_max_offset_hz : 0.0;
  if (cal.coil_frequency_hz - tracked - snr_outer_bins * bin <= 0.0 ||
      cal.coil_frequency_hz + tracked + snr_outer_bins * bin >= 0.5 * cal.rate_hz) {
    throw reader.error("frequency_tracking_max_offset_hz", "lets the neighbouring bins leave (0, Nyquist) for a " +
                                                               std::to_string(cal.coil_frequency_hz) + " Hz coil");
  }
  const double ma_s = geomagnetic_min_periods / cal.coil_frequency_hz;
  if (ma_s > 30.0) {
    throw reader.error("geomagnetic_min_periods", "gives a moving average longer than 30 s");
  }
}

std::string MagnetometerOptions::toYaml() const { return optionTable().toYaml(*this); }

}  // namespace vims
