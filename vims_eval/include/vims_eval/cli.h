#pragma once
/// @file cli.h
/// @brief The `vims_eval` command line (traj, loops, run), as a library function so tests can
/// drive it without spawning processes. See docs/evaluation.md.

#include <ostream>
#include <string>
#include <vector>

namespace vims {
namespace eval {

/// Exit codes of runEvalCli.
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitUsage = 2 };

/// Runs `vims_eval <args...>` (args without the program name). Reports and summary lines go
/// to `out`, errors to `err`. Returns kExitOk, kExitFailure (missing/malformed input, empty
/// association, ...) or kExitUsage (bad command line).
int runEvalCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

/// The --help text.
std::string evalUsage();

}  // namespace eval
}  // namespace vims
