#pragma once
/// @file eval_options.h
/// @brief All evaluation parameters in one typed struct, readable from YAML (the `eval:`
/// section of a config file) and overridable from the command line.

#include <string>
#include <vector>

#include "vims_common/config_reader.h"
#include "vims_eval/metrics.h"
#include "vims_eval/revisit.h"

namespace vims {

template <typename Options>
class OptionTable;

namespace eval {

struct EvalOptions {
  TrajectoryEvalOptions trajectory;
  LoopScoringOptions loops;
  RevisitOptions revisit;

  /// Keys (all optional, defaults as in the structs):
  ///   max_dt_s, interpolate, max_gt_gap_s, align (a list of se3|sim3|posyaw|none, or "all"),
  ///   rpe_delta_m, loop_trans_tol_m, loop_rot_tol_deg, revisit_radius_m, revisit_gap_s,
  ///   revisit_margin_s, revisit_coil_radius_m.
  /// Unknown keys and out-of-range values throw ConfigError naming the key.
  static EvalOptions fromReader(const ConfigReader& reader);
  /// The table of the keys above (bounds): drives fromReader, validate and toYaml.
  static const OptionTable<EvalOptions>& optionTable();
  std::string toYaml() const;
  /// Range checks shared by fromReader and the command line; throws std::invalid_argument.
  void validate() const;
};

/// "all" -> se3, sim3, posyaw, none; otherwise one mode (std::invalid_argument if unknown).
std::vector<AlignmentMode> parseAlignmentList(const std::string& text);

}  // namespace eval
}  // namespace vims
