#include <gtest/gtest.h>

#include "vims_magnetometer/magnetometer_options.h"
#include "vims_magnetometer/signature_extractor.h"

using namespace vims;

namespace {
std::string errorOf(const std::string& yaml, const MagnetometerCalibration* cal = nullptr) {
  try {
    const auto reader = ConfigReader::fromString(yaml, "magnetometer.yaml");
    const auto o = MagnetometerOptions::fromReader(reader);
    if (cal) o.validateFor(*cal, reader);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(MagnetometerOptions, DefaultsAreValidAndRoundTripThroughYaml) {
  const MagnetometerOptions defaults;
  const auto again = MagnetometerOptions::fromReader(ConfigReader::fromString(defaults.toYaml()));
  EXPECT_EQ(again.toYaml(), defaults.toYaml());
  EXPECT_DOUBLE_EQ(defaults.window_s, 2.0);
  EXPECT_DOUBLE_EQ(defaults.hop_s, 0.4);
  EXPECT_NO_THROW(defaults.validateFor(MagnetometerCalibration{}, ConfigReader::fromString("")));
}

TEST(MagnetometerOptions, ReadsValuesIncludingTheAttitudeSection) {
  const auto o = MagnetometerOptions::fromReader(
      ConfigReader::fromString("window_s: 3\nhop_s: 0.5\nattitude: {heading_time_constant_s: 8}\n"));
  EXPECT_DOUBLE_EQ(o.window_s, 3.0);
  EXPECT_DOUBLE_EQ(o.hop_s, 0.5);
  EXPECT_DOUBLE_EQ(o.attitude.heading_time_constant_s, 8.0);
  EXPECT_DOUBLE_EQ(o.attitude.tilt_time_constant_s, AttitudeFilterOptions{}.tilt_time_constant_s);
}

TEST(MagnetometerOptions, ErrorsNameTheKey) {
  EXPECT_NE(errorOf("windows_s: 2\n").find("magnetometer.yaml: windows_s: unknown key"), std::string::npos);
  EXPECT_NE(errorOf("attitude: {tilt_tau: 1}\n").find("attitude.tilt_tau: unknown key"), std::string::npos);
  EXPECT_NE(errorOf("attitude: {max_imu_gap_s: -1}\n").find("attitude.max_imu_gap_s"), std::string::npos);
  EXPECT_NE(errorOf("hop_s: 3\n").find("hop_s: must not exceed window_s"), std::string::npos);
  EXPECT_NE(errorOf("hop_s: 0\n").find("hop_s: must be > 0"), std::string::npos);
  EXPECT_NE(errorOf("min_snr: x\n").find("min_snr: value"), std::string::npos);
  EXPECT_NE(errorOf("snr_inner_bins: 1\n").find("snr_inner_bins"), std::string::npos);
  EXPECT_NE(errorOf("snr_outer_bins: 2\n").find("snr_outer_bins"), std::string::npos);
  EXPECT_NE(errorOf("geomagnetic_min_periods: 0\n").find("geomagnetic_min_periods"), std::string::npos);
  EXPECT_NE(errorOf("window_s: .inf\n").find("window_s"), std::string::npos);
}

TEST(MagnetometerOptions, ValidateForChecksTheSensor) {
  MagnetometerCalibration cal;  // 1000 Hz, 11 Hz coil
  EXPECT_NE(errorOf("window_s: 0.3\nhop_s: 0.1\n", &cal).find("window_s: holds only"), std::string::npos);
  EXPECT_NE(errorOf("snr_outer_bins: 30\n", &cal).find("snr_outer_bins: puts neighbouring bins"), std::string::npos);
  EXPECT_NE(errorOf("hop_s: 0.0001\n", &cal).find("hop_s: is shorter than one sample"), std::string::npos);
  EXPECT_EQ(errorOf("", &cal), "");
}

TEST(MagnetometerOptions, ExtractorRejectsOptionsThatDoNotFitTheSensor) {
  MagnetometerOptions o;
  o.window_s = 0.2;
  o.hop_s = 0.1;
  EXPECT_THROW(SignatureExtractor(o, MagnetometerCalibration{}, 9.81), ConfigError);
}
