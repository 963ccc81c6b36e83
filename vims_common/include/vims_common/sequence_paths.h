#pragma once
/// @file sequence_paths.h
/// @brief Locates the files of a sequence directory `<seq>/` (see the sensor data contract):
/// `<seq>.bag`, `<seq>.yaml`, optional `<seq>_gt.tum` and `<seq>_truth.yaml`.

#include <string>

namespace vims {

struct SequencePaths {
  std::string dir;
  std::string name;   ///< <seq>
  std::string bag;    ///< always present (checked)
  std::string yaml;   ///< always present (checked)
  std::string gt;     ///< empty when the sequence has no ground truth
  std::string truth;  ///< empty when absent (evaluation only, never read by the estimator)

  /// Resolves the files in `dir`. The name is the directory's basename; if `<name>.bag` is not
  /// there but the directory holds exactly one `.bag`, that bag's stem is the name (so a
  /// renamed directory still works). Throws std::runtime_error naming the missing file.
  static SequencePaths resolve(const std::string& dir);
  /// Paths for writing a new sequence named `name` into `dir` (nothing is checked).
  static SequencePaths forWriting(const std::string& dir, const std::string& name);
};

}  // namespace vims
