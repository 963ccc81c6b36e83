#include "vims_common/wrap_angle.h"

#include <cmath>

namespace vims {

double wrapAngle(double angle) {
  // std::remainder returns angle - n * 2pi with n the nearest integer: a result in [-pi, pi].
  return std::remainder(angle, 2.0 * M_PI);
}

}  // namespace vims
