// Truth file round trip, command-line parsing and the seeded set-up (rig vs world seeds).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "vims_common/config_reader.h"
#include "vims_common/sequence_config.h"
#include "vims_sim/sim_options.h"
#include "vims_sim/sim_setup.h"
#include "vims_sim/sim_truth.h"

using namespace vims::sim;
namespace fs = std::filesystem;

namespace {

fs::path tempPath(const std::string& stem) {
  return fs::temp_directory_path() / (stem + "_" + std::to_string(::getpid()) + "_" +
                                      ::testing::UnitTest::GetInstance()->current_test_info()->name());
}

std::string errorOf(const std::vector<std::string>& args) {
  try {
    parseSimCommandLine(args);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SimTruth, SaveLoadRoundTripIsExact) {
  SimOptions options;
  options.scenario = Scenario::kField;
  options.duration = 42.5;
  options.seed = 12345678901234ULL;
  options.world_seed = 77;
  options.out_dir = "/tmp/x/seq_a";
  options.camera_delay = 0.0321;
  options.spans.camera_blackout = {{1.0, 2.5}};
  options.spans.imu_gap = {{3.0, 3.25}, {10.0, 11.0}};
  const SimTruth truth = buildSimSetup(options).truth;
  const fs::path path = tempPath("vims_truth") += ".yaml";
  truth.save(path.string());
  const SimTruth loaded = SimTruth::load(path.string());
  fs::remove(path);
  EXPECT_EQ(loaded.scenario, "field");
  EXPECT_EQ(loaded.name, "seq_a");
  EXPECT_EQ(loaded.trajectory_seed, 12345678901234ULL);
  EXPECT_EQ(loaded.world_seed, 77u);
  EXPECT_EQ(loaded.duration, 42.5);
  EXPECT_EQ(loaded.start_time, truth.start_time);
  EXPECT_EQ(loaded.camera_time_delay, 0.0321);
  EXPECT_EQ(loaded.coil.position_w, truth.coil.position_w);
  EXPECT_EQ(loaded.coil.phase, truth.coil.phase);
  EXPECT_EQ(loaded.coil.turns, 330);
  EXPECT_EQ(loaded.coil.current, 2.9);
  EXPECT_EQ(loaded.coil.diameter, 0.6);
  EXPECT_EQ(loaded.coil.frequency, 11.0);
  EXPECT_EQ(loaded.geomagnetic.total, truth.geomagnetic.total);
  EXPECT_EQ(loaded.geomagnetic.inclination_deg, truth.geomagnetic.inclination_deg);
  EXPECT_EQ(loaded.geomagnetic.declination_deg, truth.geomagnetic.declination_deg);
  EXPECT_EQ(loaded.gyro_bias, truth.gyro_bias);
  EXPECT_EQ(loaded.accel_bias, truth.accel_bias);
  ASSERT_EQ(loaded.dropouts.imu_gap.size(), 2u);
  EXPECT_EQ(loaded.dropouts.imu_gap[1].begin, 10.0);
  EXPECT_EQ(loaded.dropouts.camera_blackout[0].end, 2.5);
  EXPECT_TRUE(loaded.dropouts.sonar_off.empty());
  EXPECT_EQ(loaded.toYaml(), truth.toYaml());
}

TEST(SimTruth, LoadRejectsUnknownAndInconsistentKeys) {
  SimOptions options;
  options.duration = 10;
  options.seed = 1;
  options.out_dir = "/tmp/x/seq_b";
  const std::string yaml = buildSimSetup(options).truth.toYaml();
  const fs::path path = tempPath("vims_truth_bad") += ".yaml";
  auto expectError = [&](const std::string& text, const std::string& key) {
    {
      std::ofstream out(path);
      out << text;
    }
    try {
      SimTruth::load(path.string());
      ADD_FAILURE() << "no error for " << key;
    } catch (const vims::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  expectError(yaml + "colour: blue\n", "colour");
  std::string wrong_turns = yaml;
  wrong_turns.replace(wrong_turns.find("turns: 330"), 10, "turns: 331");
  expectError(wrong_turns, "moment_enu");
  fs::remove(path);
}

TEST(SimCommandLine, ParsesEveryOption) {
  const auto options = parseSimCommandLine(
      {"--scenario", "field", "--duration", "60", "--seed", "4", "--out", "/tmp/runs/dive_07/", "--world-seed", "9",
       "--static-start", "2.5", "--camera-delay", "0.04", "--camera-blackout", "10:12", "--camera-off", "20:21",
       "--camera-off", "30:30.5", "--sonar-off", "5:6", "--mag-off", "7:8", "--imu-gap", "9:9.2", "--start-time",
       "1600000000.5", "--lz4", "--threads", "1"});
  ASSERT_TRUE(options.has_value());
  EXPECT_EQ(options->scenario, Scenario::kField);
  EXPECT_EQ(options->duration, 60.0);
  EXPECT_EQ(options->seed, 4u);
  EXPECT_EQ(options->worldSeed(), 9u);
  EXPECT_EQ(options->sequenceName(), "dive_07");
  EXPECT_EQ(options->static_start, 2.5);
  EXPECT_EQ(options->camera_delay, 0.04);
  ASSERT_EQ(options->spans.camera_off.size(), 2u);
  EXPECT_EQ(options->spans.camera_off[1].end, 30.5);
  EXPECT_EQ(options->spans.imu_gap[0].begin, 9.0);
  EXPECT_EQ(options->start_time, 1600000000.5);
  EXPECT_TRUE(options->lz4);
  EXPECT_EQ(options->render_threads, 1);

  const auto defaults = parseSimCommandLine({"--scenario", "tank", "--duration", "5", "--seed", "3", "--out", "d",
                                             "--name", "custom"});
  ASSERT_TRUE(defaults.has_value());
  EXPECT_EQ(defaults->worldSeed(), 3u);
  EXPECT_EQ(defaults->sequenceName(), "custom");
  EXPECT_EQ(defaults->static_start, 3.0);
  EXPECT_EQ(defaults->start_time, 1700000000.0);
  EXPECT_FALSE(defaults->lz4);
  EXPECT_FALSE(parseSimCommandLine({"--help"}).has_value());
}

TEST(SimCommandLine, ErrorsNameTheArgument) {
  const std::vector<std::string> base = {"--scenario", "tank", "--duration", "20", "--seed", "1", "--out", "d"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  EXPECT_NE(errorOf({"--duration", "20", "--seed", "1", "--out", "d"}).find("--scenario"), std::string::npos);
  EXPECT_NE(errorOf({"--scenario", "tank", "--seed", "1", "--out", "d"}).find("--duration"), std::string::npos);
  EXPECT_NE(errorOf({"--scenario", "tank", "--duration", "5", "--out", "d"}).find("--seed"), std::string::npos);
  EXPECT_NE(errorOf({"--scenario", "tank", "--duration", "5", "--seed", "1"}).find("--out"), std::string::npos);
  EXPECT_NE(errorOf(with({"--scenario", "lake"})).find("--scenario"), std::string::npos);
  EXPECT_NE(errorOf(with({"--duration", "abc"})).find("--duration"), std::string::npos);
  EXPECT_NE(errorOf(with({"--duration", "-3"})).find("--duration"), std::string::npos);
  EXPECT_NE(errorOf(with({"--seed", "-1"})).find("--seed"), std::string::npos);
  EXPECT_NE(errorOf(with({"--camera-off", "5"})).find("--camera-off"), std::string::npos);
  EXPECT_NE(errorOf(with({"--imu-gap", "6:5"})).find("--imu-gap"), std::string::npos);
  EXPECT_NE(errorOf(with({"--mag-off", "x:5"})).find("--mag-off"), std::string::npos);
  EXPECT_NE(errorOf(with({"--static-start", "25"})).find("--static-start"), std::string::npos);
  EXPECT_NE(errorOf(with({"--camera-delay", "2"})).find("--camera-delay"), std::string::npos);
  EXPECT_NE(errorOf(with({"--bogus", "1"})).find("--bogus"), std::string::npos);
  EXPECT_NE(errorOf(with({"--world-seed"})).find("--world-seed"), std::string::npos);
  EXPECT_NE(errorOf(with({"stray"})).find("stray"), std::string::npos);
}

TEST(SimSetup, WorldSeedFixesTheSiteAndSeedFixesTheRig) {
  SimOptions a;
  a.duration = 30;
  a.seed = 1;
  a.world_seed = 50;
  a.out_dir = "/tmp/x/a";
  SimOptions b = a;
  b.seed = 2;
  SimOptions c = a;
  c.world_seed = 51;
  const SimSetup sa = buildSimSetup(a), sb = buildSimSetup(b), sc = buildSimSetup(c);
  EXPECT_EQ(sa.truth.coil.position_w, sb.truth.coil.position_w);
  EXPECT_EQ(sa.truth.geomagnetic.fieldEnu(), sb.truth.geomagnetic.fieldEnu());
  EXPECT_EQ(sa.config.magnetometer.declination_deg, sb.config.magnetometer.declination_deg);
  EXPECT_GT((sa.truth.coil.position_w - sc.truth.coil.position_w).norm(), 0.1);
  EXPECT_GT((sa.config.camera.T_b_c.matrix() - sb.config.camera.T_b_c.matrix()).norm(), 1e-4);
  EXPECT_NE(sa.truth.gyro_bias, sb.truth.gyro_bias);

  for (const SimSetup* s : {&sa, &sb, &sc}) {
    // Site: ~49 uT, ~46 deg down, a few degrees of declination; coil on the seabed in the area.
    EXPECT_NEAR(s->truth.geomagnetic.fieldEnu().norm(), 49e-6, 1.5e-6);
    EXPECT_NEAR(s->truth.geomagnetic.inclination_deg, 46.0, 1.0);
    EXPECT_GE(std::abs(s->truth.geomagnetic.declination_deg), 2.0);
    EXPECT_LE(std::abs(s->truth.geomagnetic.declination_deg), 6.0);
    EXPECT_EQ(s->truth.coil.position_w.z(), 0.0);
    EXPECT_LT(s->truth.coil.position_w.head<2>().cwiseAbs().maxCoeff(), 10.0);
    // Rig: camera looking down (optical axis within 3.5 deg of body -z), ahead of the IMU.
    const Eigen::Vector3d optical_axis_b = s->config.camera.T_b_c.linear().col(2);
    EXPECT_GT(-optical_axis_b.z(), std::cos(3.5 * M_PI / 180));
    EXPECT_GT(s->config.camera.T_b_c.translation().x(), 0.2);
    EXPECT_GT(-s->config.sonar.T_b_s.linear().col(2).z(), std::cos(3.5 * M_PI / 180));
    EXPECT_NEAR(s->config.camera.fx, 420.0, 5.0);
    EXPECT_NEAR(s->config.camera.fy, 420.0, 7.0);
  }
}

TEST(SimSetup, SequenceYamlFollowsTheContract) {
  SimOptions options;
  options.duration = 30;
  options.seed = 8;
  options.out_dir = "/tmp/x/c";
  const SimSetup setup = buildSimSetup(options);
  const fs::path path = tempPath("vims_seq") += ".yaml";
  setup.config.save(path.string());
  std::vector<std::string> unknown;
  const vims::SequenceConfig loaded = vims::SequenceConfig::load(path.string(), &unknown);
  fs::remove(path);
  EXPECT_TRUE(unknown.empty());
  EXPECT_EQ(loaded.camera.width, 640);
  EXPECT_EQ(loaded.camera.height, 480);
  EXPECT_EQ(loaded.camera.rate_hz, 10.0);
  EXPECT_EQ(loaded.imu.rate_hz, 200.0);
  EXPECT_EQ(loaded.sonar.rate_hz, 10.0);
  EXPECT_EQ(loaded.magnetometer.rate_hz, 1000.0);
  EXPECT_EQ(loaded.magnetometer.coil_frequency_hz, 11.0);
  EXPECT_NEAR(loaded.magnetometer.noise_std, 5e-9, 1e-15);
  EXPECT_NEAR(loaded.sonar.range_noise_std, 0.02, 1e-12);
  EXPECT_LT((loaded.camera.T_b_c.matrix() - setup.config.camera.T_b_c.matrix()).norm(), 1e-9);
}
