#pragma once
/// @file tool_runner.h
/// @brief Helpers for system tests that run the project's command-line tools (vims_offline,
/// vims_eval, ...) and look at their output files. Header-only; tests only.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <sstream>
#include <string>

namespace vims {
namespace test {

struct CommandResult {
  int exit_code = -1;  ///< -1 when the command could not be run or did not exit normally
  std::string output;  ///< stdout and stderr, interleaved
};

/// Runs `command` through the shell and collects its output and exit status.
inline CommandResult runCommand(const std::string& command) {
  CommandResult result;
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen((command + " 2>&1").c_str(), "r"), pclose);
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe.get())) result.output += buffer.data();
  const int status = pclose(pipe.release());
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

/// The key=value pairs of the first line of `text` that starts with `prefix` (a tool's summary
/// line, e.g. "VIMS_EVAL label=vio"); empty when there is none.
inline std::map<std::string, std::string> summaryValues(const std::string& text, const std::string& prefix) {
  std::map<std::string, std::string> kv;
  const auto pos = text.find(prefix);
  if (pos == std::string::npos) return kv;
  std::istringstream line(text.substr(pos, text.find('\n', pos) - pos));
  std::string item;
  while (line >> item) {
    const auto eq = item.find('=');
    if (eq != std::string::npos) kv[item.substr(0, eq)] = item.substr(eq + 1);
  }
  return kv;
}

/// `name` in the folder of simulated test sequences (env VIMS_TEST_DATA, set by ctest through
/// vims_require_sequence); empty when the variable is not set.
inline std::string testSequence(const std::string& name) {
  const char* dir = std::getenv("VIMS_TEST_DATA");
  return dir ? std::string(dir) + "/" + name : std::string();
}

/// An empty directory below gtest's temporary directory (removed first if it exists).
inline std::filesystem::path freshDir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace test
}  // namespace vims
