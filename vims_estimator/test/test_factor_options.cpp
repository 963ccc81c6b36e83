// FactorOptions: defaults, round trip through YAML, and rejection of unknown keys / bad values.
#include <gtest/gtest.h>

#include "vims_estimator/factor_options.h"

namespace vims {
namespace {

TEST(FactorOptions, EmptySectionGivesDefaultsAndYamlRoundTrips) {
  const FactorOptions defaults = FactorOptions::fromReader(ConfigReader::fromString("{}"));
  EXPECT_DOUBLE_EQ(defaults.reprojection.pixel_sigma, ReprojectionOptions().pixel_sigma);

  FactorOptions changed;
  changed.reprojection.pixel_sigma = 0.8;
  changed.sonar_depth.flatness_std = 0.02;
  changed.sonar_depth.misfit_per_m = 0.7;
  changed.sonar_depth.learn_misfit = false;
  changed.sonar_depth.misfit_history_hits = 40;
  changed.sonar_depth.misfit_min_pairs = 12;
  changed.sonar_depth.gate_chi2 = 3.84;
  changed.sonar_depth.carry_seabed_through_outages = false;
  changed.sonar_depth.carry_slope_std = 0.1;
  changed.sonar_depth.carry_max_distance_m = 4.0;
  changed.imu_preintegration.max_gyro_bias_change = 0.005;
  changed.marginalization.eigenvalue_relative_threshold = 1e-9;
  const FactorOptions back = FactorOptions::fromReader(ConfigReader::fromString(changed.toYaml()));
  EXPECT_DOUBLE_EQ(back.reprojection.pixel_sigma, 0.8);
  EXPECT_DOUBLE_EQ(back.sonar_depth.flatness_std, 0.02);
  EXPECT_DOUBLE_EQ(back.sonar_depth.misfit_per_m, 0.7);
  EXPECT_FALSE(back.sonar_depth.learn_misfit);
  EXPECT_EQ(back.sonar_depth.misfit_history_hits, 40);
  EXPECT_EQ(back.sonar_depth.misfit_min_pairs, 12);
  EXPECT_DOUBLE_EQ(back.sonar_depth.gate_chi2, 3.84);
  EXPECT_FALSE(back.sonar_depth.carry_seabed_through_outages);
  EXPECT_DOUBLE_EQ(back.sonar_depth.carry_slope_std, 0.1);
  EXPECT_DOUBLE_EQ(back.sonar_depth.carry_max_distance_m, 4.0);
  EXPECT_DOUBLE_EQ(back.imu_preintegration.max_gyro_bias_change, 0.005);
  EXPECT_DOUBLE_EQ(back.marginalization.eigenvalue_relative_threshold, 1e-9);
  EXPECT_NEAR(back.sonar_depth.sigma(0.03), std::sqrt(0.03 * 0.03 + 0.02 * 0.02), 1e-15);
}

TEST(FactorOptions, UnknownKeysAndBadValuesNameTheKey) {
  try {
    FactorOptions::fromReader(ConfigReader::fromString("sonar_depth: {flatnes_std: 0.1}"));
    FAIL() << "misspelt key accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("sonar_depth.flatnes_std"), std::string::npos) << e.what();
  }
  try {
    FactorOptions::fromReader(ConfigReader::fromString("reprojection: {pixel_sigma: -1}"));
    FAIL() << "negative sigma accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("reprojection.pixel_sigma"), std::string::npos) << e.what();
  }
  EXPECT_THROW(FactorOptions::fromReader(ConfigReader::fromString("imu: {}")), ConfigError);
  EXPECT_THROW(FactorOptions::fromReader(ConfigReader::fromString("sonar_depth: {carry_slope_std: -0.1}")),
               ConfigError);
  EXPECT_THROW(FactorOptions::fromReader(ConfigReader::fromString("sonar_depth: {misfit_per_m: -0.1}")), ConfigError);
  EXPECT_THROW(FactorOptions::fromReader(ConfigReader::fromString("sonar_depth: {misfit_history_hits: 0}")),
               ConfigError);
  EXPECT_THROW(FactorOptions::fromReader(ConfigReader::fromString("sonar_depth: {misfit_min_pairs: -3}")), ConfigError);
  EXPECT_THROW(FactorOptions::fromReader(ConfigReader::fromString("sonar_depth: {carry_max_distance_m: 0}")),
               ConfigError);
  EXPECT_THROW(
      FactorOptions::fromReader(ConfigReader::fromString("marginalization: {eigenvalue_absolute_threshold: 0}")),
      ConfigError);
}

}  // namespace
}  // namespace vims
