#pragma once
/// @file pressure_depth_filter.h
/// @brief Converts pressure samples to depths and drops what is not a depth: non-finite or
/// non-positive pressures, and spikes (a sample far from the median of the recent window).

#include <deque>
#include <string>

#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"
#include "vims_estimator/seabed_options.h"

namespace vims {

class PressureDepthFilter {
 public:
  struct Result {
    bool accepted = false;
    double t = 0.0;
    double depth = 0.0;            ///< [m] below the surface, from the YAML's atmospheric_pa and density
    std::string rejected_because;  ///< empty when accepted
  };

  PressureDepthFilter(const PressureCalibration& calibration, double gravity, const PressureOptions& options);

  /// Every sample enters the median window (the median rides over isolated spikes, and a real
  /// depth step is followed after half a window); the sample is accepted when it lies within
  /// spike_threshold_m of the median of the window's other samples (or the window is still short).
  Result add(const PressureSample& sample);
  void clear() { window_.clear(); }

 private:
  PressureCalibration calibration_;
  double gravity_;
  PressureOptions options_;
  std::deque<std::pair<double, double>> window_;  ///< (t, depth) within median_window_s
};

}  // namespace vims
