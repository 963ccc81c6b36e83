#pragma once
/// @file seabed_options.h
/// @brief Options of the estimator's seabed model and of the pressure depth factor (sections
/// `seabed` and `pressure` of the `estimator` configuration). docs/factors.md 5c and 5d give the
/// math; docs/estimator.md how the window uses them.

#include <string>

#include "vims_common/config_reader.h"

namespace vims {

template <typename Options>
class OptionTable;

/// How the sonar depth factor relates a feature to the seabed point under the sonar.
enum class SeabedModel {
  kHorizontal,  ///< the paper's: the feature is at the height of the beam's hit (flat, level seabed)
  kLocalPlane,  ///< the feature is on a plane through the hit whose gradient is a window state
};
const char* seabedModelName(SeabedModel model);

struct SeabedModelOptions {
  /// local_plane: real seabeds slope by a few degrees, and on a 4 deg slope the horizontal model
  /// puts a feature 1.5 m from the beam spot 0.1 m off, which tilts the estimated attitude.
  SeabedModel model = SeabedModel::kLocalPlane;
  /// [1/sqrt(m)] Random walk of the gradient per metre travelled between keyframes: rolling
  /// relief of 0.3 m over 30 m changes the slope by ~0.013 per metre; 0.02 lets the plane follow
  /// that without reacting to the roughness of single features.
  double slope_random_walk = 0.02;
  /// Floor of the gradient's change between two keyframes (a hovering vehicle still sees its
  /// footprint's seabed change as features come and go).
  double slope_step_std = 0.002;
  /// Prior of the gradient at a session's start (no slope known): 0.15 (8.5 deg) covers the
  /// slopes an AUV surveys; it only keeps the plane defined until features observe it.
  double slope_prior_std = 0.15;
  /// Bound of each gradient component in the solve: 0.36 = 20 deg, steeper is a wall, not a seabed.
  double max_slope = 0.36;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<SeabedModelOptions>& optionTable();

  /// Reads {model, slope_random_walk, slope_step_std, slope_prior_std, max_slope}; unknown keys
  /// or bad values throw ConfigError naming the key.
  static SeabedModelOptions fromReader(const ConfigReader& reader);
  std::string toYaml() const;
};

struct PressureOptions {
  /// Use the pressure depth factor when the sequence has a pressure sensor (its YAML has a
  /// `pressure` section). false ignores the sensor (ablation).
  bool enabled = true;
  /// [m] Floor on the depth noise of the factor: the YAML's noise_std_pa may be 0 for an ideal
  /// simulation, and waves and the vehicle's own flow make ~5 mm of pressure noise at depth.
  double min_depth_std_m = 0.005;
  /// [m] A sample this far from the median depth of the last median_window_s is a spike
  /// (a bubble on the port, an electrical glitch) and is dropped; an AUV changes depth by at
  /// most a few decimetres per second.
  double spike_threshold_m = 0.3;
  /// [s] Length of that median window (its sample count follows the YAML's rate).
  double median_window_s = 1.0;
  /// Huber scale of the pressure factor in whitened units.
  double loss_scale = 1.0;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<PressureOptions>& optionTable();

  /// Reads {enabled, min_depth_std_m, spike_threshold_m, median_window_s, loss_scale}.
  static PressureOptions fromReader(const ConfigReader& reader);
  std::string toYaml() const;
};

}  // namespace vims
