#include "vims_tracking/tracker_options.h"

#include <cmath>
#include <set>
#include <sstream>
#include <string>
#include <type_traits>

namespace vims {

namespace {

/// Calls `visit(key, member, lo, hi)` for every option, so reading, range checking and printing
/// share one table and cannot drift apart. Bounds are inclusive; booleans have none.
template <typename Options, typename Visitor>
void forEachOption(Options& o, Visitor&& visit) {
  visit("max_features", o.max_features, 1, 5000);
  visit("min_distance_px", o.min_distance_px, 1.0, 200.0);
  visit("border_px", o.border_px, 0, 100);
  visit("detect_min_missing", o.detect_min_missing, 1, 5000);
  visit("quality_level", o.quality_level, 1e-6, 1.0);
  visit("min_quality_level", o.min_quality_level, 1e-6, 1.0);
  visit("quality_decrease_factor", o.quality_decrease_factor, 0.01, 0.99);
  visit("min_corner_response", o.min_corner_response, 0.0, 1.0);
  visit("illumination_sigma_px", o.illumination_sigma_px, 0.0, 1000.0);
  visit("illumination_target_mean", o.illumination_target_mean, 1.0, 255.0);
  visit("clahe_enabled", o.clahe_enabled, false, true);
  visit("clahe_clip_limit", o.clahe_clip_limit, 0.1, 100.0);
  visit("clahe_tiles", o.clahe_tiles, 1, 64);
  visit("blank_frame_max_stddev", o.blank_frame_max_stddev, 0.0, 50.0);
  visit("max_frame_gap_s", o.max_frame_gap_s, 0.001, 3600.0);
  visit("klt_window_px", o.klt_window_px, 5, 101);
  visit("klt_max_level", o.klt_max_level, 0, 8);
  visit("klt_max_iterations", o.klt_max_iterations, 1, 1000);
  visit("klt_epsilon", o.klt_epsilon, 1e-6, 1.0);
  visit("klt_min_eigen_threshold", o.klt_min_eigen_threshold, 1e-9, 1.0);
  visit("fb_max_error_px", o.fb_max_error_px, 0.01, 50.0);
  visit("ransac_enabled", o.ransac_enabled, false, true);
  visit("ransac_threshold_px", o.ransac_threshold_px, 0.01, 50.0);
  visit("ransac_confidence", o.ransac_confidence, 0.5, 0.999999);
  visit("ransac_max_iterations", o.ransac_max_iterations, 10, 100000);
}

std::string formatNumber(double value) {
  std::ostringstream os;
  os << value;
  return os.str();
}

/// Checks relations between options; `fail(key, message)` must throw.
template <typename Fail>
void checkRelations(const TrackerOptions& o, Fail&& fail) {
  if (o.detect_min_missing > o.max_features) {
    fail("detect_min_missing", "must be <= max_features (" + std::to_string(o.max_features) + "), got " +
                                   std::to_string(o.detect_min_missing));
  }
  if (o.min_quality_level > o.quality_level) {
    fail("min_quality_level",
         "must be <= quality_level (" + formatNumber(o.quality_level) + "), got " + formatNumber(o.min_quality_level));
  }
}

}  // namespace

TrackerOptions TrackerOptions::fromReader(const ConfigReader& reader) {
  TrackerOptions options;
  std::set<std::string> known;
  forEachOption(options, [&](const char* key, auto&, auto, auto) { known.insert(key); });
  reader.rejectUnknownKeys(known);
  forEachOption(options, [&](const char* key, auto& member, auto lo, auto hi) {
    using T = std::decay_t<decltype(member)>;
    member = reader.get<T>(key, member);
    if constexpr (!std::is_same_v<T, bool>) {
      requireInRange(reader, key, static_cast<double>(member), static_cast<double>(lo), static_cast<double>(hi));
    }
  });
  checkRelations(options,
                 [&](const std::string& key, const std::string& message) -> void { throw reader.error(key, message); });
  return options;
}

void TrackerOptions::validate() const {
  auto fail = [](const std::string& key, const std::string& message) -> void {
    throw ConfigError("tracker option " + key + ": " + message);
  };
  forEachOption(*this, [&](const char* key, const auto& member, auto lo, auto hi) {
    using T = std::decay_t<decltype(member)>;
    if constexpr (!std::is_same_v<T, bool>) {
      const double value = static_cast<double>(member);
      if (!(value >= static_cast<double>(lo) && value <= static_cast<double>(hi))) {
        fail(key, "must be in [" + formatNumber(lo) + ", " + formatNumber(hi) + "], got " + formatNumber(value));
      }
    }
  });
  checkRelations(*this, fail);
}

std::string TrackerOptions::toYaml() const {
  std::ostringstream os;
  forEachOption(*this, [&](const char* key, const auto& member, auto, auto) {
    using T = std::decay_t<decltype(member)>;
    os << key << ": ";
    if constexpr (std::is_same_v<T, bool>) {
      os << (member ? "true" : "false");
    } else {
      os << member;
    }
    os << "\n";
  });
  return os.str();
}

}  // namespace vims
