#include "vims_tracking/tracker_options.h"

#include <string>

#include "vims_common/option_table.h"

namespace vims {

const OptionTable<TrackerOptions>& TrackerOptions::optionTable() {
  using O = TrackerOptions;
  static const auto table =
      OptionTable<O>()
          .integer("max_features", &O::max_features, Bounds::closed(1, 5000))
          .number("min_distance_px", &O::min_distance_px, Bounds::closed(1.0, 200.0))
          .integer("border_px", &O::border_px, Bounds::closed(0, 100))
          .integer("detect_min_missing", &O::detect_min_missing, Bounds::closed(1, 5000))
          .number("quality_level", &O::quality_level, Bounds::closed(1e-6, 1.0))
          .number("min_quality_level", &O::min_quality_level, Bounds::closed(1e-6, 1.0))
          .number("quality_decrease_factor", &O::quality_decrease_factor, Bounds::closed(0.01, 0.99))
          .number("min_corner_response", &O::min_corner_response, Bounds::closed(0.0, 1.0))
          .number("illumination_sigma_px", &O::illumination_sigma_px, Bounds::closed(0.0, 1000.0))
          .number("illumination_target_mean", &O::illumination_target_mean, Bounds::closed(1.0, 255.0))
          .flag("clahe_enabled", &O::clahe_enabled)
          .number("clahe_clip_limit", &O::clahe_clip_limit, Bounds::closed(0.1, 100.0))
          .integer("clahe_tiles", &O::clahe_tiles, Bounds::closed(1, 64))
          .number("blank_frame_max_stddev", &O::blank_frame_max_stddev, Bounds::closed(0.0, 50.0))
          .number("max_frame_gap_s", &O::max_frame_gap_s, Bounds::closed(0.001, 3600.0))
          .integer("klt_window_px", &O::klt_window_px, Bounds::closed(5, 101))
          .integer("klt_max_level", &O::klt_max_level, Bounds::closed(0, 8))
          .integer("klt_max_iterations", &O::klt_max_iterations, Bounds::closed(1, 1000))
          .number("klt_epsilon", &O::klt_epsilon, Bounds::closed(1e-6, 1.0))
          .number("klt_min_eigen_threshold", &O::klt_min_eigen_threshold, Bounds::closed(1e-9, 1.0))
          .number("fb_max_error_px", &O::fb_max_error_px, Bounds::closed(0.01, 50.0))
          .flag("ransac_enabled", &O::ransac_enabled)
          .number("ransac_threshold_px", &O::ransac_threshold_px, Bounds::closed(0.01, 50.0))
          .number("ransac_confidence", &O::ransac_confidence, Bounds::closed(0.5, 0.999999))
          .integer("ransac_max_iterations", &O::ransac_max_iterations, Bounds::closed(10, 100000))
          .rule([](const O& o) {
            return violationIf(o.detect_min_missing > o.max_features, "detect_min_missing",
                               "must be <= max_features (" + std::to_string(o.max_features) + "), got " +
                                   std::to_string(o.detect_min_missing));
          })
          .rule([](const O& o) {
            return violationIf(o.min_quality_level > o.quality_level, "min_quality_level",
                               "must be <= quality_level (" + formatOptionNumber(o.quality_level) + "), got " +
                                   formatOptionNumber(o.min_quality_level));
          });
  return table;
}

TrackerOptions TrackerOptions::fromReader(const ConfigReader& reader) { return readOptions<TrackerOptions>(reader); }

void TrackerOptions::validate() const {
  if (const auto v = optionTable().firstViolation(*this)) {
    throw ConfigError("tracker option " + v->key + ": " + v->message);
  }
}

std::string TrackerOptions::toYaml() const { return optionTable().toYaml(*this); }

}  // namespace vims
