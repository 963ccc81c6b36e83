#pragma once
/// @file rig_file.h
/// @brief A vehicle's rig for vims_sim (--rig FILE): its camera, mounting and sensor rates, written
/// as the vims_sim flags they stand for (config/rigs/*.yaml).
///
/// A rig file is a YAML mapping from flag names (without the leading dashes) to values:
///
///     distortion-model: equidistant
///     image-width: 1024
///     camera-tilt-deg: 30
///     imu-rate-hz: 400
///
/// Each value means what the flag means (vims_sim --help); a flag on the command line overrides
/// the file's.

#include <string>
#include <vector>

namespace vims {
namespace sim {

/// The flags a rig file may set (without the leading dashes).
const std::vector<std::string>& rigFlagNames();

/// The file's entries as command-line arguments ("--flag", "value", ...), in the file's order.
/// Throws std::invalid_argument naming the file and, where it is one, the key: an unreadable or
/// malformed file, a key that is not a rig flag, a value that is not a scalar.
std::vector<std::string> rigFileArguments(const std::string& path);

}  // namespace sim
}  // namespace vims
