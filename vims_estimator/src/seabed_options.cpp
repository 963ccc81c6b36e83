#include "vims_estimator/seabed_options.h"

#include <sstream>

namespace vims {

const char* seabedModelName(SeabedModel model) {
  return model == SeabedModel::kHorizontal ? "horizontal" : "local_plane";
}

SeabedModelOptions SeabedModelOptions::fromReader(const ConfigReader& r) {
  r.rejectUnknownKeys({"model", "slope_random_walk", "slope_step_std", "slope_prior_std", "max_slope"});
  SeabedModelOptions o;
  const std::string model = r.get<std::string>("model", seabedModelName(o.model));
  if (model == "horizontal") {
    o.model = SeabedModel::kHorizontal;
  } else if (model == "local_plane") {
    o.model = SeabedModel::kLocalPlane;
  } else {
    throw r.error("model", "must be 'horizontal' or 'local_plane', got '" + model + "'");
  }
  readInRange(r, "slope_random_walk", &o.slope_random_walk, 0.0, 1.0);
  readInRange(r, "slope_step_std", &o.slope_step_std, 1e-6, 1.0);
  readInRange(r, "slope_prior_std", &o.slope_prior_std, 1e-4, 10.0);
  readInRange(r, "max_slope", &o.max_slope, 0.01, 1.0);
  return o;
}

std::string SeabedModelOptions::toYaml() const {
  std::ostringstream os;
  os << "model: " << seabedModelName(model) << "\nslope_random_walk: " << slope_random_walk
     << "\nslope_step_std: " << slope_step_std << "\nslope_prior_std: " << slope_prior_std
     << "\nmax_slope: " << max_slope << "\n";
  return os.str();
}

PressureOptions PressureOptions::fromReader(const ConfigReader& r) {
  r.rejectUnknownKeys({"enabled", "min_depth_std_m", "spike_threshold_m", "median_window_s", "loss_scale"});
  PressureOptions o;
  o.enabled = r.get<bool>("enabled", o.enabled);
  readInRange(r, "min_depth_std_m", &o.min_depth_std_m, 1e-4, 1.0);
  readInRange(r, "spike_threshold_m", &o.spike_threshold_m, 0.01, 100.0);
  readInRange(r, "median_window_s", &o.median_window_s, 0.05, 60.0);
  readInRange(r, "loss_scale", &o.loss_scale, 1e-3, 100.0);
  return o;
}

std::string PressureOptions::toYaml() const {
  std::ostringstream os;
  os << "enabled: " << (enabled ? "true" : "false") << "\nmin_depth_std_m: " << min_depth_std_m
     << "\nspike_threshold_m: " << spike_threshold_m << "\nmedian_window_s: " << median_window_s
     << "\nloss_scale: " << loss_scale << "\n";
  return os.str();
}

}  // namespace vims
