#include <gtest/gtest.h>

#include "vims_estimator/estimator_options.h"

namespace {

TEST(EstimatorOptions, DefaultsAndRoundTrip) {
  const vims::EstimatorOptions defaults = vims::EstimatorOptions::fromReader(vims::ConfigReader::fromString("{}"));
  EXPECT_EQ(defaults.window_size, 10);
  EXPECT_TRUE(defaults.use_sonar);
  // toYaml() is readable by fromReader() and gives the same values.
  const vims::EstimatorOptions again =
      vims::EstimatorOptions::fromReader(vims::ConfigReader::fromString(defaults.toYaml()));
  EXPECT_EQ(again.toYaml(), defaults.toYaml());
}

TEST(EstimatorOptions, ReadsValues) {
  const auto o = vims::EstimatorOptions::fromReader(
      vims::ConfigReader::fromString("{window_size: 8, use_sonar: false, estimate_td: true, td_initial_s: 0.01, "
                                     "factors: {reprojection: {pixel_sigma: 2.0}}}"));
  EXPECT_EQ(o.window_size, 8);
  EXPECT_FALSE(o.use_sonar);
  EXPECT_TRUE(o.estimate_td);
  EXPECT_DOUBLE_EQ(o.td_initial_s, 0.01);
  EXPECT_DOUBLE_EQ(o.factors.reprojection.pixel_sigma, 2.0);
}

TEST(EstimatorOptions, RejectsUnknownAndBadValuesNamingTheKey) {
  auto message = [](const std::string& yaml) {
    try {
      vims::EstimatorOptions::fromReader(vims::ConfigReader::fromString(yaml));
    } catch (const vims::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message("{window_sise: 10}").find("window_sise"), std::string::npos);
  EXPECT_NE(message("{window_size: 1}").find("window_size"), std::string::npos);
  EXPECT_NE(message("{keyframe_parallax_px: -1}").find("keyframe_parallax_px"), std::string::npos);
  EXPECT_NE(message("{td_initial_s: 0.3}").find("td_initial_s"), std::string::npos);
  EXPECT_NE(message("{min_feature_depth_m: 2, max_feature_depth_m: 1}").find("max_feature_depth_m"), std::string::npos);
  EXPECT_NE(message("{factors: {reprojection: {pixel_sigma: 0}}}").find("pixel_sigma"), std::string::npos);
  EXPECT_NE(message("{use_sonar: maybe}").find("use_sonar"), std::string::npos);
}

}  // namespace
