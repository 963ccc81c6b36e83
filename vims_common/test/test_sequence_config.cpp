#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "vims_common/sequence_config.h"

using vims::ConfigError;
using vims::ConfigReader;
using vims::SequenceConfig;

namespace {
const char* kContractExample = R"(
topics: {image: /cam0/image_raw, imu: /imu0, sonar: /sonar/range, mag: /mag/raw}
camera:
  model: pinhole
  width: 640
  height: 480
  intrinsics: [400, 401, 320, 240]
  distortion: [-0.05, 0.01, 0.001, -0.0005]
  T_b_c: [0,-1,0,0.3, -1,0,0,0, 0,0,-1,-0.1, 0,0,0,1]
  rate_hz: 10
imu:
  rate_hz: 200
  gyro_noise_density: 0.00012
  gyro_random_walk: 0.00002
  accel_noise_density: 0.0006
  accel_random_walk: 0.0001
  gravity: 9.81
sonar:
  T_b_s: [1,0,0,0.1, 0,-1,0,0, 0,0,-1,-0.2, 0,0,0,1]
  rate_hz: 10
  range_noise_std: 0.02
  min_range: 0.1
  max_range: 50.0
magnetometer:
  T_b_m: [1,0,0,0, 0,1,0,0, 0,0,1,0.3, 0,0,0,1]
  rate_hz: 1000
  noise_std: 5.0e-9
  coil_frequency_hz: 11.0
  declination_deg: 3.5
)";

std::string errorOf(const std::string& yaml) {
  try {
    SequenceConfig::fromReader(ConfigReader::fromString(yaml, "seq.yaml"));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  return s.replace(pos, from.size(), to);
}
}  // namespace

TEST(SequenceConfig, ParsesTheContractExample) {
  std::vector<std::string> unknown;
  const auto cfg = SequenceConfig::fromReader(ConfigReader::fromString(kContractExample), &unknown);
  EXPECT_TRUE(unknown.empty());
  EXPECT_EQ(cfg.camera.width, 640);
  EXPECT_DOUBLE_EQ(cfg.camera.fy, 401);
  EXPECT_DOUBLE_EQ(cfg.camera.distortion[3], -0.0005);
  EXPECT_NEAR((cfg.camera.T_b_c.translation() - Eigen::Vector3d(0.3, 0, -0.1)).norm(), 0, 1e-12);
  // Camera optical axis (+z) points down in the body frame.
  EXPECT_NEAR((cfg.camera.T_b_c.linear() * Eigen::Vector3d::UnitZ() - Eigen::Vector3d(0, 0, -1)).norm(), 0, 1e-12);
  EXPECT_DOUBLE_EQ(cfg.magnetometer.declination_deg, 3.5);
  EXPECT_DOUBLE_EQ(cfg.sonar.range_noise_std, 0.02);
}

TEST(SequenceConfig, SaveLoadRoundTrip) {
  const auto cfg = SequenceConfig::fromReader(ConfigReader::fromString(kContractExample));
  const std::string path = ::testing::TempDir() + "/vims_seq_roundtrip.yaml";
  cfg.save(path);
  const auto back = SequenceConfig::load(path);
  EXPECT_EQ(back.topics.mag, cfg.topics.mag);
  EXPECT_DOUBLE_EQ(back.camera.cx, cfg.camera.cx);
  EXPECT_NEAR((back.sonar.T_b_s.matrix() - cfg.sonar.T_b_s.matrix()).norm(), 0, 1e-9);
  EXPECT_DOUBLE_EQ(back.imu.accel_random_walk, cfg.imu.accel_random_walk);
  EXPECT_DOUBLE_EQ(back.magnetometer.noise_std, cfg.magnetometer.noise_std);
  std::remove(path.c_str());
}

TEST(SequenceConfig, BadValuesNameTheirKey) {
  const std::string base = kContractExample;
  EXPECT_NE(errorOf(replace(base, "width: 640", "width: -640")).find("camera.width"), std::string::npos);
  EXPECT_NE(errorOf(replace(base, "intrinsics: [400, 401, 320, 240]", "intrinsics: [400, 320, 240]"))
                .find("camera.intrinsics: expected 4 numbers"),
            std::string::npos);
  EXPECT_NE(errorOf(replace(base, "  rate_hz: 200", "  rate_hz: 0")).find("imu.rate_hz"), std::string::npos);
  EXPECT_NE(errorOf(replace(base, "coil_frequency_hz: 11.0", "coil_frequency_hz: 600")).find("coil_frequency_hz"),
            std::string::npos);
  EXPECT_NE(errorOf(replace(base, "max_range: 50.0", "max_range: 0.05")).find("sonar.max_range"), std::string::npos);
  EXPECT_NE(errorOf(replace(base, "model: pinhole", "model: fisheye")).find("camera.model"), std::string::npos);
  EXPECT_NE(
      errorOf(replace(base, "gyro_noise_density: 0.00012", "gyro_noise_density: abc")).find("imu.gyro_noise_density"),
      std::string::npos);
}

TEST(SequenceConfig, MissingSectionIsNamed) {
  const std::string yaml = std::string(kContractExample).substr(0, std::string(kContractExample).find("\nsonar:"));
  EXPECT_NE(errorOf(yaml).find("sonar: required section is missing"), std::string::npos);
}

TEST(SequenceConfig, ExtraKeysFromOtherRecordersAreReportedNotFatal) {
  std::vector<std::string> unknown;
  const std::string yaml = std::string(kContractExample) + "recorder: {version: 3}\n";
  EXPECT_NO_THROW(SequenceConfig::fromReader(ConfigReader::fromString(yaml), &unknown));
  ASSERT_EQ(unknown.size(), 1u);
  EXPECT_EQ(unknown[0], "recorder");
}

namespace {
const char* kPressureSection = R"(pressure:
  T_b_p: [1,0,0,-0.4, 0,1,0,0, 0,0,1,0.1, 0,0,0,1]
  rate_hz: 10
  noise_std_pa: 30.0
  atmospheric_pa: 101325.0
  water_density: 1025.0
)";
}  // namespace

TEST(SequenceConfig, VersionOneSequenceHasNoPressureAndSavesWithoutIt) {
  const auto cfg = SequenceConfig::fromReader(ConfigReader::fromString(kContractExample));
  EXPECT_FALSE(cfg.pressure.has_value());
  EXPECT_EQ(cfg.toYaml().find("pressure"), std::string::npos);
}

TEST(SequenceConfig, PressureSectionParsesConvertsAndRoundTrips) {
  std::vector<std::string> unknown;
  const std::string yaml =
      replace(kContractExample, "mag: /mag/raw}", "mag: /mag/raw, pressure: /depth/p}") + kPressureSection;
  const auto cfg = SequenceConfig::fromReader(ConfigReader::fromString(yaml), &unknown);
  EXPECT_TRUE(unknown.empty());
  ASSERT_TRUE(cfg.pressure.has_value());
  EXPECT_EQ(cfg.topics.pressure, "/depth/p");
  EXPECT_NEAR(cfg.pressure->T_b_p.translation().x(), -0.4, 1e-12);
  // 10 m of sea water: 1025 * 9.81 * 10 Pa above the atmosphere.
  EXPECT_NEAR(cfg.pressure->depthOf(101325.0 + 1025.0 * 9.81 * 10.0, 9.81), 10.0, 1e-9);
  EXPECT_NEAR(cfg.pressure->depthStd(9.81), 30.0 / (1025.0 * 9.81), 1e-12);
  const auto back = SequenceConfig::fromReader(ConfigReader::fromString(cfg.toYaml()));
  ASSERT_TRUE(back.pressure.has_value());
  EXPECT_EQ(back.topics.pressure, "/depth/p");
  EXPECT_DOUBLE_EQ(back.pressure->noise_std_pa, 30.0);
  EXPECT_NEAR((back.pressure->T_b_p.matrix() - cfg.pressure->T_b_p.matrix()).norm(), 0, 1e-9);
}

TEST(SequenceConfig, BadPressureValuesNameTheirKey) {
  const std::string yaml = std::string(kContractExample) + kPressureSection;
  // An atmospheric pressure in hPa or bar is a unit error, not a weather change.
  EXPECT_NE(
      errorOf(replace(yaml, "atmospheric_pa: 101325.0", "atmospheric_pa: 1013.25")).find("pressure.atmospheric_pa"),
      std::string::npos);
  EXPECT_NE(errorOf(replace(yaml, "water_density: 1025.0", "water_density: 1.025")).find("pressure.water_density"),
            std::string::npos);
  EXPECT_NE(
      errorOf(replace(yaml, "  rate_hz: 10\n  noise_std_pa", "  rate_hz: 0\n  noise_std_pa")).find("pressure.rate_hz"),
      std::string::npos);
  EXPECT_NE(errorOf(replace(yaml, "T_b_p: [1,0,0,-0.4,", "T_b_p: [1,0,0,")).find("pressure.T_b_p"), std::string::npos);
}

// Contract version 2: camera.distortion_model radtan (the default, version 1) or equidistant.
TEST(SequenceConfig, DistortionModelParsesRoundTripsAndRejectsOthers) {
  const std::string base = kContractExample;
  EXPECT_EQ(SequenceConfig::fromReader(ConfigReader::fromString(base)).camera.distortion_model,
            vims::DistortionModel::kRadtan);
  const std::string fisheye = replace(base, "  distortion: [", "  distortion_model: equidistant\n  distortion: [");
  std::vector<std::string> unknown;
  const auto cfg = SequenceConfig::fromReader(ConfigReader::fromString(fisheye), &unknown);
  EXPECT_EQ(cfg.camera.distortion_model, vims::DistortionModel::kEquidistant);
  EXPECT_TRUE(unknown.empty()) << unknown.front();
  const std::string path = ::testing::TempDir() + "/vims_seq_fisheye.yaml";
  cfg.save(path);
  EXPECT_EQ(SequenceConfig::load(path).camera.distortion_model, vims::DistortionModel::kEquidistant);
  std::remove(path.c_str());
  const std::string bad = replace(base, "  distortion: [", "  distortion_model: plumb_bob\n  distortion: [");
  EXPECT_NE(errorOf(bad).find("camera.distortion_model: expected radtan or equidistant, got 'plumb_bob'"),
            std::string::npos)
      << errorOf(bad);
}

TEST(SequenceConfig, CoilFrequencyMayBeAListNullOrAbsent) {
  const std::string base = kContractExample;
  auto coils = [](const std::string& yaml) {
    return SequenceConfig::fromReader(ConfigReader::fromString(yaml)).magnetometer;
  };
  EXPECT_DOUBLE_EQ(coils(base).coil_frequency_hz, 11.0);
  EXPECT_TRUE(coils(base).other_coil_frequencies_hz.empty());
  // Several coils: the first is the one signatures are extracted at.
  const auto two = coils(replace(base, "coil_frequency_hz: 11.0", "coil_frequency_hz: [17.0, 11.0]"));
  EXPECT_DOUBLE_EQ(two.coil_frequency_hz, 17.0);
  EXPECT_EQ(two.other_coil_frequencies_hz, std::vector<double>{11.0});
  // null or absent: found from the data.
  for (const std::string& open : {replace(base, "coil_frequency_hz: 11.0", "coil_frequency_hz: null"),
                                  replace(base, "  coil_frequency_hz: 11.0\n", "")}) {
    const auto m = coils(open);
    EXPECT_FALSE(m.coilFrequencyKnown());
    EXPECT_TRUE(m.other_coil_frequencies_hz.empty());
  }
  EXPECT_NE(errorOf(replace(base, "coil_frequency_hz: 11.0", "coil_frequency_hz: []")).find("coil_frequency_hz"),
            std::string::npos);
  EXPECT_NE(errorOf(replace(base, "coil_frequency_hz: 11.0", "coil_frequency_hz: [11.0, 700]"))
                .find("coil_frequency_hz: must be below the Nyquist"),
            std::string::npos);
  // Each form survives save and load.
  for (const std::string& form : {std::string("[17.0, 11.0]"), std::string("null")}) {
    const auto cfg = SequenceConfig::fromReader(
        ConfigReader::fromString(replace(base, "coil_frequency_hz: 11.0", "coil_frequency_hz: " + form)));
    const std::string path = ::testing::TempDir() + "/vims_seq_coils.yaml";
    cfg.save(path);
    const auto back = SequenceConfig::load(path).magnetometer;
    EXPECT_EQ(back.coil_frequency_hz, cfg.magnetometer.coil_frequency_hz) << form;
    EXPECT_EQ(back.other_coil_frequencies_hz, cfg.magnetometer.other_coil_frequencies_hz) << form;
    std::remove(path.c_str());
  }
}
