#pragma once
/// @file truth_coils.h
/// @brief The coils' positions from a sequence's `<seq>_truth.yaml` (evaluation only), for
/// counting the revisit events near each coil (revisit.h, revisitsNearCoils).

#include <Eigen/Core>
#include <string>
#include <vector>

namespace vims {
namespace eval {

/// Coil positions in the order of the sequence's coil_frequency_hz list: `coil.position_enu`,
/// then `other_coils[i].position_enu` (vims_sim's truth file; vims_sim/docs/simulator.md).
/// The truth file is optional in the contract and its layout is the generator's: a file without
/// these keys gives an empty list (and `why` says so), never an error. A file that cannot be
/// parsed, or a position that is not three numbers, throws std::runtime_error naming the key.
std::vector<Eigen::Vector3d> readTruthCoilPositions(const std::string& truth_path, std::string* why);

}  // namespace eval
}  // namespace vims
