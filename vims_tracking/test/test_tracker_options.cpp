#include <gtest/gtest.h>

#include "vims_tracking/feature_tracker.h"
#include "vims_tracking/tracker_options.h"

namespace {

std::string errorOf(const std::string& yaml) {
  try {
    vims::TrackerOptions::fromReader(vims::ConfigReader::fromString(yaml, "test.yaml").child("tracker"));
  } catch (const vims::ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(TrackerOptions, DefaultsAreValid) { EXPECT_NO_THROW(vims::TrackerOptions().validate()); }

TEST(TrackerOptions, ReadsGivenKeysAndKeepsDefaultsForOthers) {
  const vims::TrackerOptions o = vims::TrackerOptions::fromReader(
      vims::ConfigReader::fromString("tracker: {max_features: 200, fb_max_error_px: 0.5, clahe_enabled: false}")
          .child("tracker"));
  EXPECT_EQ(o.max_features, 200);
  EXPECT_DOUBLE_EQ(o.fb_max_error_px, 0.5);
  EXPECT_FALSE(o.clahe_enabled);
  EXPECT_DOUBLE_EQ(o.min_distance_px, vims::TrackerOptions().min_distance_px);
}

TEST(TrackerOptions, RejectsUnknownKeyNamingIt) {
  const std::string message = errorOf("tracker: {max_featurs: 100}");
  EXPECT_NE(message.find("tracker.max_featurs"), std::string::npos) << message;
}

TEST(TrackerOptions, RejectsOutOfRangeNamingTheKey) {
  EXPECT_NE(errorOf("tracker: {max_features: 0}").find("tracker.max_features"), std::string::npos);
  EXPECT_NE(errorOf("tracker: {ransac_confidence: 1.5}").find("tracker.ransac_confidence"), std::string::npos);
  EXPECT_NE(errorOf("tracker: {fb_max_error_px: .nan}").find("tracker.fb_max_error_px"), std::string::npos);
  EXPECT_NE(errorOf("tracker: {klt_max_level: -1}").find("tracker.klt_max_level"), std::string::npos);
  EXPECT_NE(errorOf("tracker: {detect_min_missing: 0}").find("tracker.detect_min_missing"), std::string::npos);
  // More missing features than the budget holds would never detect again.
  EXPECT_NE(errorOf("tracker: {max_features: 10, detect_min_missing: 11}").find("detect_min_missing"),
            std::string::npos);
}

TEST(TrackerOptions, RejectsWrongTypeNamingTheKey) {
  EXPECT_NE(errorOf("tracker: {klt_window_px: 21.5}").find("tracker.klt_window_px"), std::string::npos);
  EXPECT_NE(errorOf("tracker: {ransac_enabled: maybe}").find("tracker.ransac_enabled"), std::string::npos);
}

TEST(TrackerOptions, RejectsMinQualityAboveQuality) {
  const std::string message = errorOf("tracker: {quality_level: 0.001, min_quality_level: 0.01}");
  EXPECT_NE(message.find("tracker.min_quality_level"), std::string::npos) << message;
}

TEST(TrackerOptions, YamlRoundTrip) {
  vims::TrackerOptions o;
  o.max_features = 123;
  o.ransac_enabled = false;
  o.quality_level = 0.02;
  const vims::TrackerOptions back = vims::TrackerOptions::fromReader(vims::ConfigReader::fromString(o.toYaml()));
  EXPECT_EQ(back.toYaml(), o.toYaml());
}

TEST(TrackerOptions, ValidateAndTrackerRejectOptionsBuiltInCode) {
  vims::TrackerOptions o;
  o.klt_window_px = 3;
  EXPECT_THROW(o.validate(), vims::ConfigError);
  vims::CameraCalibration calibration;
  calibration.fx = calibration.fy = 400;
  calibration.cx = 320;
  calibration.cy = 240;
  EXPECT_THROW(vims::FeatureTracker(calibration, o), vims::ConfigError);
}
