#pragma once
/// @file test_files.h
/// @brief Helpers of the pose-graph tests that write files or expect errors.

#include <unistd.h>

#include <exception>
#include <filesystem>
#include <functional>
#include <string>

namespace vims {
namespace test {

/// A path in the temporary directory unique to this process: `<tmp>/vims_<prefix>_<pid>_<name>`.
inline std::string tempPath(const std::string& prefix, const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("vims_" + prefix + "_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

/// The what() of the exception `f` throws; empty when it throws none.
inline std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace test
}  // namespace vims
