#include "vims_sonar/sonar_filter_options.h"

#include "vims_common/option_table.h"

namespace vims {

const OptionTable<SonarFilterOptions>& SonarFilterOptions::optionTable() {
  using O = SonarFilterOptions;
  // A line needs 2 points and the leave-one-out check of acquisition a third.
  static const auto table =
      OptionTable<O>()
          .integer("window_size", &O::window_size, Bounds::closed(3, 200))
          .number("gate_sigma", &O::gate_sigma, Bounds::closed(1.0, 20.0))
          .number("min_noise_std_m", &O::min_noise_std_m, Bounds::positive())
          .number("max_range_accel_mps2", &O::max_range_accel_mps2, Bounds::nonNegative())
          .number("max_gap_s", &O::max_gap_s, Bounds::positive())
          .integer("acquire_samples", &O::acquire_samples, Bounds::closed(3, 50))
          .rule([](const O& o) {
            return violationIf(o.window_size < o.acquire_samples, "window_size",
                               "must be >= acquire_samples (" + std::to_string(o.acquire_samples) + "), got " +
                                   std::to_string(o.window_size));
          });
  return table;
}

SonarFilterOptions SonarFilterOptions::fromReader(const ConfigReader& reader) {
  return readOptions<SonarFilterOptions>(reader);
}

void SonarFilterOptions::validate(const ConfigReader& reader) const {
  if (const auto v = optionTable().firstViolation(*this)) throw reader.error(v->key, v->message);
}

std::string SonarFilterOptions::toYaml() const { return optionTable().toYaml(*this); }

}  // namespace vims
