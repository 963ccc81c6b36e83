/// SystemConfig: the one loader of the system configuration (sections, files, checks) and the one
/// mapping of the ablation modes, which vims_offline and the nodes share.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "vims_system/system_config.h"

namespace vims {
namespace {

namespace fs = std::filesystem;

/// Writes `text` to a file in a fresh temporary folder and returns its path.
class ConfigFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vims_system_config_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const fs::path path = dir_ / name;
    std::ofstream(path) << text;
    return path.string();
  }
  std::string errorOf(const std::vector<std::string>& paths) {
    try {
      SystemConfig::load(paths, SequenceConfig{});
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(ConfigFiles, NoFileGivesTheDefaults) {
  const SystemConfig config = SystemConfig::load({}, SequenceConfig{});
  EXPECT_EQ(config.sonar.toYaml(), SonarFilterOptions().toYaml());
  EXPECT_EQ(config.estimator.toYaml(), EstimatorOptions().toYaml());
  EXPECT_EQ(config.pose_graph.toYaml(), PoseGraphManagerOptions().toYaml());
}

TEST_F(ConfigFiles, SectionsComeFromAnyOfTheFiles) {
  const std::string a = write("a.yaml", "sonar: {window_size: 9}\nestimator: {window_size: 8}\n");
  const std::string b = write("b.yaml", "pose_graph: {optimise_every_n_keyframes: 7}\n");
  const SystemConfig config = SystemConfig::load({a, b}, SequenceConfig{});
  EXPECT_EQ(config.sonar.window_size, 9);
  EXPECT_EQ(config.estimator.window_size, 8);
  EXPECT_EQ(config.pose_graph.optimise_every_n_keyframes, 7);
  EXPECT_EQ(config.tracker.toYaml(), TrackerOptions().toYaml());  // not given: defaults
}

TEST_F(ConfigFiles, ErrorsNameTheFileAndTheKey) {
  const std::string section = write("section.yaml", "sonr: {window_size: 9}\n");
  EXPECT_NE(errorOf({section}).find("section.yaml: sonr: unknown key"), std::string::npos) << errorOf({section});
  const std::string key = write("key.yaml", "sonar: {windw_size: 9}\n");
  EXPECT_NE(errorOf({key}).find("key.yaml: sonar.windw_size: unknown key"), std::string::npos) << errorOf({key});
  const std::string twice = write("twice.yaml", "sonar: {window_size: 5}\n");
  const std::string message = errorOf({twice, twice});
  EXPECT_NE(message.find("sonar: the section is also given in"), std::string::npos) << message;
  EXPECT_NE(errorOf({(dir_ / "missing.yaml").string()}).find("missing.yaml"), std::string::npos);
}

/// The magnetometer's options are checked against the sequence's sensor, here as in every node.
TEST_F(ConfigFiles, MagnetometerOptionsAreCheckedAgainstTheSensor) {
  SequenceConfig slow;
  slow.magnetometer.rate_hz = 20.0;  // Nyquist 10 Hz: the 11 Hz coil cannot be seen
  EXPECT_THROW(SystemConfig::load({}, slow), ConfigError);
}

TEST(SystemModes, EachModeSetsTheEstimatorAndThePoseGraph) {
  for (const std::string& mode : SystemConfig::modes()) {
    SystemConfig config;
    config.applyMode(mode);
    EXPECT_EQ(config.estimator.use_sonar, mode != "no_sonar") << mode;
    EXPECT_EQ(toString(config.pose_graph.mode), mode == "no_sonar" ? "full" : mode) << mode;
  }
  SystemConfig sonar_off;
  sonar_off.estimator.use_sonar = false;  // configured off: no mode turns it on
  sonar_off.applyMode("full");
  EXPECT_FALSE(sonar_off.estimator.use_sonar);
}

TEST(SystemModes, AnUnknownModeIsAnErrorListingTheKnownOnes) {
  SystemConfig config;
  try {
    config.applyMode("no_sonr");
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown mode 'no_sonr' (known: full, vi_slam, no_sonar"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace vims
