#pragma once
/// @file factor_options.h
/// @brief All options of the estimator's mathematical building blocks in one typed struct, so the
/// estimator's own options can embed it as one YAML section:
/// ```yaml
/// factors:
///   imu_preintegration: {max_accel_bias_change: 0.1, max_gyro_bias_change: 0.01}
///   reprojection: {pixel_sigma: 1.5}
///   sonar_depth: {flatness_std: 0.05, gate_chi2: 6.635, gate_max_height_difference: 0.5}
///   marginalization: {eigenvalue_relative_threshold: 1.0e-10, eigenvalue_absolute_threshold: 1.0e-8}
/// ```
/// Calibration (IMU noise densities, sonar range noise, camera intrinsics, extrinsics) is not
/// here: it comes from the sequence YAML (vims_common/sequence_config.h).

#include <string>

#include "vims_common/config_reader.h"
#include "vims_estimator/factors/reprojection_factor.h"
#include "vims_estimator/factors/sonar_depth_factor.h"
#include "vims_estimator/imu_preintegration.h"
#include "vims_estimator/marginalization.h"

namespace vims {

template <typename Options>
class OptionTable;

struct FactorOptions {
  ImuPreintegrationOptions imu_preintegration;
  ReprojectionOptions reprojection;
  SonarDepthOptions sonar_depth;
  MarginalizationOptions marginalization;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<FactorOptions>& optionTable();

  /// Reads the four optional sub-sections; unknown keys and out-of-range values throw
  /// ConfigError naming the full key path.
  static FactorOptions fromReader(const ConfigReader& reader);
  /// YAML of all values (the format fromReader reads).
  std::string toYaml() const;
};

}  // namespace vims
