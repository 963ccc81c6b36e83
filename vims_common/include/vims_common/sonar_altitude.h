#pragma once
/// @file sonar_altitude.h
/// @brief The sonar altitude filter's output (vims_sonar), as every consumer sees it: the
/// estimator, the offline runner, the ROS conversions (vims/FilteredSonarRange). Here, not in
/// vims_sonar, so the back ends depend on the front end's results and not on the front end.

namespace vims {

enum class SonarStatus {
  kOk,         ///< accepted; `filtered` is the trend-following median
  kOutlier,    ///< rejected by the gate (or inconsistent during acquisition)
  kDropout,    ///< no valid range: +inf/NaN, outside [min_range, max_range], or a duplicate stamp
  kWarmingUp,  ///< no trusted trend yet and not (yet) part of a consistent set; not accepted
  kReset,      ///< this sample reset the filter (gap, clock backwards) and was not accepted
};

/// "ok", "outlier", "dropout", "warming_up", "reset" (the CSV and log spelling).
const char* sonarStatusName(SonarStatus status);

/// The filter's verdict on one input sample.
struct SonarFilterResult {
  double t = 0.0;             ///< stamp of the input sample [s]
  double raw = 0.0;           ///< input range [m] as received (may be +inf)
  double filtered = 0.0;      ///< filtered range at t [m]; valid only when has_estimate
  bool has_estimate = false;  ///< a trusted trend existed at t (false while warming up)
  bool accepted = false;      ///< the raw range was accepted as a good measurement
  SonarStatus status = SonarStatus::kWarmingUp;
};

}  // namespace vims
