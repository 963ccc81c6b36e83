#include "vims_eval/cli_args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace vims {
namespace eval {

CliArgs::CliArgs(const std::vector<std::string>& args, std::size_t first, const std::map<std::string, bool>& allowed,
                 const std::string& command) {
  for (std::size_t i = first; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a.size() < 3 || a.compare(0, 2, "--") != 0) throw UsageError(command + ": unexpected argument '" + a + "'");
    const std::string name = a.substr(2);
    const auto spec = allowed.find(name);
    if (spec == allowed.end()) throw UsageError(command + ": unknown option '" + a + "'");
    if (values_.count(name)) throw UsageError(command + ": option '" + a + "' given twice");
    if (spec->second) {
      if (i + 1 >= args.size()) throw UsageError(command + ": option '" + a + "' needs a value");
      values_[name] = args[++i];
    } else {
      values_[name] = "";
    }
  }
}

std::string CliArgs::required(const std::string& name, const std::string& command) const {
  if (!has(name)) throw UsageError(command + ": option --" + name + " is required");
  return values_.at(name);
}

std::string CliArgs::get(const std::string& name, const std::string& fallback) const {
  return has(name) ? values_.at(name) : fallback;
}

void CliArgs::number(const std::string& name, double* value) const {
  if (!has(name)) return;
  const std::string& text = values_.at(name);
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v))
    throw UsageError("option --" + name + ": '" + text + "' is not a number");
  *value = v;
}

void CliArgs::integer(const std::string& name, int min_value, int max_value, int* value) const {
  if (!has(name)) return;
  const std::string& text = values_.at(name);
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || v < min_value || v > max_value)
    throw UsageError("option --" + name + ": '" + text + "' is not a whole number in [" + std::to_string(min_value) +
                     ", " + std::to_string(max_value) + "]");
  *value = static_cast<int>(v);
}

std::map<std::string, bool> mergeOptions(std::initializer_list<std::map<std::string, bool>> parts) {
  std::map<std::string, bool> out;
  for (const auto& p : parts) out.insert(p.begin(), p.end());
  return out;
}

}  // namespace eval
}  // namespace vims
