#include "vims_ros/sonar_conversions.h"

#include <cmath>

#include "vims_ros/odometry_conversions.h"

namespace vims {
namespace {

// The message's status constants are SonarStatus's values.
static_assert(static_cast<int>(SonarStatus::kOk) == vims::FilteredSonarRange::STATUS_OK);
static_assert(static_cast<int>(SonarStatus::kOutlier) == vims::FilteredSonarRange::STATUS_OUTLIER);
static_assert(static_cast<int>(SonarStatus::kDropout) == vims::FilteredSonarRange::STATUS_DROPOUT);
static_assert(static_cast<int>(SonarStatus::kWarmingUp) == vims::FilteredSonarRange::STATUS_WARMING_UP);
static_assert(static_cast<int>(SonarStatus::kReset) == vims::FilteredSonarRange::STATUS_RESET);

bool fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

}  // namespace

bool toFilteredSonarRangeMsg(const SonarFilterResult& result, const std::string& frame_id,
                             vims::FilteredSonarRange* out, std::string* why) {
  if (std::isnan(result.raw)) return fail(why, "raw range is NaN");
  if (result.has_estimate && !std::isfinite(result.filtered)) return fail(why, "non-finite filtered range");
  if (!toRosTime(result.t, &out->header.stamp, why)) return false;
  out->header.frame_id = frame_id;
  out->raw = result.raw;
  out->filtered = result.has_estimate ? result.filtered : 0.0;
  out->has_estimate = result.has_estimate;
  out->accepted = result.accepted;
  out->status = static_cast<std::uint8_t>(result.status);
  return true;
}

bool toSonarFilterResult(const vims::FilteredSonarRange& msg, SonarFilterResult* out, std::string* why) {
  if (msg.status > vims::FilteredSonarRange::STATUS_RESET)
    return fail(why, "unknown status " + std::to_string(msg.status));
  if (std::isnan(msg.raw)) return fail(why, "raw range is NaN");
  if (msg.has_estimate && !(std::isfinite(msg.filtered) && msg.filtered > 0.0)) {
    return fail(why, "filtered range is not a positive finite number");
  }
  if (msg.accepted && (!msg.has_estimate || msg.status != vims::FilteredSonarRange::STATUS_OK)) {
    return fail(why, "an accepted range needs an estimate and status OK");
  }
  out->t = msg.header.stamp.toSec();
  out->raw = msg.raw;
  out->filtered = msg.filtered;
  out->has_estimate = msg.has_estimate;
  out->accepted = msg.accepted;
  out->status = static_cast<SonarStatus>(msg.status);
  return true;
}

}  // namespace vims
