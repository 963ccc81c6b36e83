#pragma once
/// @file sim_options_test_support.h
/// @brief What the command-line tests of vims_sim share.

#include <stdexcept>
#include <string>
#include <vector>

#include "vims_sim/sim_options.h"

namespace vims {
namespace sim {
namespace test {

/// The message parseSimCommandLine throws for `args`; empty when it throws nothing.
inline std::string commandLineError(const std::vector<std::string>& args) {
  try {
    parseSimCommandLine(args);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace test
}  // namespace sim
}  // namespace vims
