#include "vims_common/sonar_altitude.h"

namespace vims {

const char* sonarStatusName(SonarStatus status) {
  switch (status) {
    case SonarStatus::kOk:
      return "ok";
    case SonarStatus::kOutlier:
      return "outlier";
    case SonarStatus::kDropout:
      return "dropout";
    case SonarStatus::kWarmingUp:
      return "warming_up";
    case SonarStatus::kReset:
      return "reset";
  }
  return "?";
}

}  // namespace vims
