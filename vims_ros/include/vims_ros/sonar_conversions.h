#pragma once
/// @file sonar_conversions.h
/// @brief vims/FilteredSonarRange <-> SonarFilterResult: the sonar filter node's output as the
/// estimator node takes it. Like conversions.h, each direction validates and returns false with
/// a reason for anything a core must not see.

#include <vims/FilteredSonarRange.h>

#include <string>

#include "vims_common/sonar_altitude.h"

namespace vims {

/// SonarFilterResult -> vims/FilteredSonarRange in `frame_id`. A filtered value without an
/// estimate goes out as 0. Rejects a time ros::Time cannot hold, a NaN raw range and a
/// non-finite filtered range with an estimate.
bool toFilteredSonarRangeMsg(const SonarFilterResult& result, const std::string& frame_id,
                             vims::FilteredSonarRange* out, std::string* why);

/// vims/FilteredSonarRange -> SonarFilterResult. Rejects an unknown status, a NaN raw range, a
/// non-finite or non-positive filtered range with an estimate, and an accepted verdict without
/// one or with a status other than OK.
bool toSonarFilterResult(const vims::FilteredSonarRange& msg, SonarFilterResult* out, std::string* why);

}  // namespace vims
