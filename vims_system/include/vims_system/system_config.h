#pragma once
/// @file system_config.h
/// @brief The system configuration every entry point loads: one shape, one loader, one mode mapping.
///
/// A system configuration is one or more YAML files whose top-level keys are sections, one per
/// module: `sonar`, `magnetometer`, `tracker`, `estimator`, `pose_graph` (the committed
/// config/<section>.yaml each hold one). vims_offline and every node load their files through
/// SystemConfig::load, so a key means the same everywhere and is checked the same way: an unknown
/// section or key, a bad value, or a section given in two files is a ConfigError naming it.

#include <string>
#include <vector>

#include "vims_common/sequence_config.h"
#include "vims_estimator/estimator_options.h"
#include "vims_magnetometer/magnetometer_options.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_sonar/sonar_filter_options.h"
#include "vims_tracking/tracker_options.h"

namespace vims {

struct OptionRow;

struct SystemConfig {
  SonarFilterOptions sonar;
  MagnetometerOptions magnetometer;
  TrackerOptions tracker;
  EstimatorOptions estimator;
  PoseGraphManagerOptions pose_graph;

  /// Every key of every section with the values it accepts, e.g. {"estimator.window_size",
  /// "whole number [2, 50]"}: what `vims_offline --list-options` prints and docs/parameters.md shows.
  static std::vector<OptionRow> optionRows();

  /// The section names, in pipeline order.
  static const std::vector<std::string>& sections();

  /// Reads `paths` (none: the built-in defaults; each file any of the sections, no section in
  /// two files; a missing section keeps its defaults) and validates the options against the
  /// sequence's sensors. Throws ConfigError naming the file and key.
  static SystemConfig load(const std::vector<std::string>& paths, const SequenceConfig& sequence);

  /// The paper's ablation modes, all on the same code path (docs/offline_outputs.md): "full";
  /// "no_sonar" (the estimator without sonar factors; loop closing as full); "vi_slam",
  /// "no_alter", "no_orb", "no_geom" (the pose graph's loop-closing modes, docs/pose_graph.md).
  static const std::vector<std::string>& modes();

  /// Sets what `mode` changes: estimator.use_sonar (off for no_sonar; otherwise as configured)
  /// and pose_graph.mode. Throws ConfigError for an unknown mode, naming the known ones.
  void applyMode(const std::string& mode);
};

}  // namespace vims
