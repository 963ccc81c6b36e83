#include <gtest/gtest.h>

#include "vims_sonar/sonar_altitude_filter.h"
#include "vims_sonar/sonar_filter_options.h"

using namespace vims;

namespace {
std::string errorOf(const std::string& yaml) {
  try {
    SonarFilterOptions::fromReader(ConfigReader::fromString(yaml, "sonar.yaml"));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(SonarFilterOptions, DefaultsAreValidAndRoundTripThroughYaml) {
  const SonarFilterOptions defaults;
  const auto again = SonarFilterOptions::fromReader(ConfigReader::fromString(defaults.toYaml()));
  EXPECT_EQ(again.toYaml(), defaults.toYaml());
  const auto empty = SonarFilterOptions::fromReader(ConfigReader::fromString(""));
  EXPECT_EQ(empty.window_size, defaults.window_size);
}

TEST(SonarFilterOptions, ReadsValues) {
  const auto o = SonarFilterOptions::fromReader(ConfigReader::fromString("window_size: 11\ngate_sigma: 6\n"));
  EXPECT_EQ(o.window_size, 11);
  EXPECT_DOUBLE_EQ(o.gate_sigma, 6.0);
}

TEST(SonarFilterOptions, ErrorsNameTheKey) {
  EXPECT_NE(errorOf("windw_size: 3\n").find("sonar.yaml: windw_size: unknown key"), std::string::npos);
  EXPECT_NE(errorOf("gate_sigma: -1\n").find("gate_sigma: must be in"), std::string::npos);
  EXPECT_NE(errorOf("gate_sigma: abc\n").find("gate_sigma: value"), std::string::npos);
  EXPECT_NE(errorOf("window_size: 2\n").find("window_size: must be in"), std::string::npos);
  EXPECT_NE(errorOf("acquire_samples: 2\n").find("acquire_samples"), std::string::npos);
  EXPECT_NE(errorOf("max_gap_s: 0\n").find("max_gap_s: must be > 0"), std::string::npos);
  EXPECT_NE(errorOf("min_noise_std_m: .nan\n").find("min_noise_std_m"), std::string::npos);
  EXPECT_NE(errorOf("max_range_accel_mps2: -0.1\n").find("max_range_accel_mps2"), std::string::npos);
}

TEST(SonarFilterOptions, FilterRejectsInvalidOptionsAtConstruction) {
  SonarFilterOptions o;
  o.window_size = 1;
  EXPECT_THROW(SonarAltitudeFilter(o, SonarCalibration{}), ConfigError);
}
