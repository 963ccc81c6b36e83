#pragma once
/// @file sim_options.h
/// @brief Options of one simulated sequence, and the `vims_sim` command line that sets them.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vims_sim/sim_truth.h"
#include "vims_sim/trajectory.h"

namespace vims {
namespace sim {

struct SimOptions {
  Scenario scenario = Scenario::kTank;
  double duration = 0.0;                ///< [s]
  uint64_t seed = 0;                    ///< trajectory seed: path, rig calibration, all noise
  std::optional<uint64_t> world_seed;   ///< seabed, coil position, site field; default = seed
  std::string out_dir;
  std::string name;                     ///< default: basename of out_dir
  double static_start = 3.0;            ///< [s]
  double camera_delay = 0.0;            ///< [s] image stamp = exposure time + delay
  DropoutSpans spans;
  double start_time = 1700000000.0;     ///< bag-clock time of the sequence start [s]
  bool lz4 = false;                     ///< lz4-compressed bag chunks
  int render_threads = 0;               ///< 0: one per hardware thread

  uint64_t worldSeed() const { return world_seed ? *world_seed : seed; }
  /// `name`, or the basename of out_dir when empty.
  std::string sequenceName() const;
  /// Throws std::invalid_argument naming the offending option (as its command-line flag).
  void validate() const;
};

/// Parses the vims_sim arguments (without the program name). Returns std::nullopt for --help.
/// Throws std::invalid_argument with a message that names the offending argument.
std::optional<SimOptions> parseSimCommandLine(const std::vector<std::string>& args);

/// The --help text.
std::string simUsage();

}  // namespace sim
}  // namespace vims
