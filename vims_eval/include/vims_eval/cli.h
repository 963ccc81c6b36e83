#pragma once
/// @file cli.h
/// @brief The `vims_eval` command line (traj, loops, run; ablation and place-recognition are
/// added by the executable from vims_eval_paper), as a library function so tests can drive it
/// without spawning processes. See docs/evaluation.md.

#include <functional>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "vims_eval/cli_args.h"
#include "vims_eval/eval_options.h"

namespace vims {
namespace eval {

/// Exit codes of runEvalCli.
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitUsage = 2 };

/// A further subcommand: gets the whole argument list (command word first); may throw
/// UsageError (exit 2), ConfigError (exit 2) or any std::exception (exit 1).
using EvalCommand = std::function<int(const std::vector<std::string>&, std::ostream&, std::ostream&)>;

/// Runs `vims_eval <args...>` (args without the program name). Reports and summary lines go
/// to `out`, errors to `err`. Returns kExitOk, kExitFailure (missing/malformed input, empty
/// association, ...) or kExitUsage (bad command line). `extra_commands` adds subcommands by name.
int runEvalCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err,
               const std::map<std::string, EvalCommand>& extra_commands = {});

/// The --help text.
std::string evalUsage();

/// The evaluation options every subcommand that evaluates trajectories and loops accepts
/// (--align, --max-dt, ..., --revisit-margin, --config), for CliArgs.
std::map<std::string, bool> evalOptionTable();
/// Defaults, then the `eval:` section of --config, then the individual flags. Throws UsageError
/// for invalid values.
EvalOptions evalOptionsFromArgs(const CliArgs& args);

}  // namespace eval
}  // namespace vims
