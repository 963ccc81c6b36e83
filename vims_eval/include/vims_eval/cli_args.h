#pragma once
/// @file cli_args.h
/// @brief `--name value` / `--flag` argument parsing shared by the vims_eval subcommands.

#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace vims {
namespace eval {

/// A command-line mistake: reported with a hint to --help and exit code 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Parsed `--name value` / `--flag` arguments of one subcommand. `allowed` maps each option
/// name (without "--") to whether it takes a value. Throws UsageError for an unexpected
/// argument, an unknown or repeated option, or a missing value.
class CliArgs {
 public:
  CliArgs(const std::vector<std::string>& args, std::size_t first, const std::map<std::string, bool>& allowed,
          const std::string& command);

  bool has(const std::string& name) const { return values_.count(name) > 0; }
  /// The option's value; UsageError naming the option when absent.
  std::string required(const std::string& name, const std::string& command) const;
  std::string get(const std::string& name, const std::string& fallback) const;
  /// Overwrites *value with the option's number when given; rejects text and non-finite values.
  void number(const std::string& name, double* value) const;
  /// Same for a whole number in [min_value, max_value].
  void integer(const std::string& name, int min_value, int max_value, int* value) const;

 private:
  std::map<std::string, std::string> values_;
};

/// Union of option tables.
std::map<std::string, bool> mergeOptions(std::initializer_list<std::map<std::string, bool>> parts);

}  // namespace eval
}  // namespace vims
