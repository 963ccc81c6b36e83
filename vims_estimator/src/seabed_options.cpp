#include "vims_estimator/seabed_options.h"

#include "vims_common/option_table.h"

namespace vims {

const char* seabedModelName(SeabedModel model) {
  return model == SeabedModel::kHorizontal ? "horizontal" : "local_plane";
}

const OptionTable<SeabedModelOptions>& SeabedModelOptions::optionTable() {
  using O = SeabedModelOptions;
  static const auto table =
      OptionTable<O>()
          .choice<SeabedModel>("model", &O::model, {SeabedModel::kHorizontal, SeabedModel::kLocalPlane},
                               seabedModelName)
          .number("slope_random_walk", &O::slope_random_walk, Bounds::closed(0.0, 1.0))
          .number("slope_step_std", &O::slope_step_std, Bounds::closed(1e-6, 1.0))
          .number("slope_prior_std", &O::slope_prior_std, Bounds::closed(1e-4, 10.0))
          .number("max_slope", &O::max_slope, Bounds::closed(0.01, 1.0));
  return table;
}

SeabedModelOptions SeabedModelOptions::fromReader(const ConfigReader& r) { return readOptions<SeabedModelOptions>(r); }

std::string SeabedModelOptions::toYaml() const { return optionTable().toYaml(*this); }

const OptionTable<PressureOptions>& PressureOptions::optionTable() {
  using O = PressureOptions;
  static const auto table = OptionTable<O>()
                                .flag("enabled", &O::enabled)
                                .number("min_depth_std_m", &O::min_depth_std_m, Bounds::closed(1e-4, 1.0))
                                .number("spike_threshold_m", &O::spike_threshold_m, Bounds::closed(0.01, 100.0))
                                .number("median_window_s", &O::median_window_s, Bounds::closed(0.05, 60.0))
                                .number("loss_scale", &O::loss_scale, Bounds::closed(1e-3, 100.0));
  return table;
}

PressureOptions PressureOptions::fromReader(const ConfigReader& r) { return readOptions<PressureOptions>(r); }

std::string PressureOptions::toYaml() const { return optionTable().toYaml(*this); }

}  // namespace vims
