#include "vims_estimator/pressure_depth_filter.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

namespace vims {

PressureDepthFilter::PressureDepthFilter(const PressureCalibration& calibration, double gravity,
                                         const PressureOptions& options)
    : calibration_(calibration), gravity_(gravity), options_(options) {}

PressureDepthFilter::Result PressureDepthFilter::add(const PressureSample& sample) {
  Result result;
  result.t = sample.t;
  if (!std::isfinite(sample.t) || !std::isfinite(sample.pressure_pa) || !(sample.pressure_pa > 0.0)) {
    result.rejected_because = "pressure is not a finite positive number";
    return result;
  }
  if (!window_.empty() && sample.t <= window_.back().first) {
    if (sample.t < window_.back().first)
      window_.clear();  // clock went backwards
    else {
      result.rejected_because = "repeated stamp";
      return result;
    }
  }
  result.depth = calibration_.depthOf(sample.pressure_pa, gravity_);
  while (!window_.empty() && window_.front().first < sample.t - options_.median_window_s) window_.pop_front();
  // The median of the window before this sample; a window of fewer than 3 samples has none.
  if (window_.size() >= 3) {
    std::vector<double> depths;
    depths.reserve(window_.size());
    for (const auto& s : window_) depths.push_back(s.second);
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
    const double median = depths[depths.size() / 2];
    if (std::abs(result.depth - median) > options_.spike_threshold_m) {
      std::ostringstream why;
      why << "spike: depth " << result.depth << " m is " << std::abs(result.depth - median)
          << " m from the median of the last " << options_.median_window_s << " s";
      result.rejected_because = why.str();
    }
  }
  window_.emplace_back(sample.t, result.depth);
  result.accepted = result.rejected_because.empty();
  return result;
}

}  // namespace vims
