#pragma once
/// @file wrap_angle.h
/// @brief Angle wrapping shared by the simulator and the pose graph.

namespace vims {

/// Wraps an angle to [-pi, pi] (std::remainder by 2 pi: the nearest multiple is taken off).
double wrapAngle(double angle);

}  // namespace vims
