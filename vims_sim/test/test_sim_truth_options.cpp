// Truth file round trip, command-line parsing and the seeded set-up (rig vs world seeds).
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Eigenvalues>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "sim_options_test_support.h"
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

/// The truth written to a temporary file and read back.
SimTruth savedAndLoaded(const SimTruth& truth, const std::string& stem) {
  const fs::path path = tempPath(stem) += ".yaml";
  truth.save(path.string());
  SimTruth loaded = SimTruth::load(path.string());
  fs::remove(path);
  return loaded;
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
  EXPECT_EQ(loaded.rig_seed, 12345678901234ULL);  // the trajectory's by default
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
  const auto options = parseSimCommandLine({"--scenario",
                                            "field",
                                            "--duration",
                                            "60",
                                            "--seed",
                                            "4",
                                            "--out",
                                            "/tmp/runs/dive_07/",
                                            "--world-seed",
                                            "9",
                                            "--static-start",
                                            "2.5",
                                            "--camera-delay",
                                            "0.04",
                                            "--camera-blackout",
                                            "10:12",
                                            "--camera-off",
                                            "20:21",
                                            "--camera-off",
                                            "30:30.5",
                                            "--sonar-off",
                                            "5:6",
                                            "--mag-off",
                                            "7:8",
                                            "--imu-gap",
                                            "9:9.2",
                                            "--start-time",
                                            "1600000000.5",
                                            "--lz4",
                                            "--image-format",
                                            "jpeg",
                                            "--threads",
                                            "1"});
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
  EXPECT_EQ(options->image_format, "jpeg");
  EXPECT_EQ(options->render_threads, 1);

  const auto defaults =
      parseSimCommandLine({"--scenario", "tank", "--duration", "5", "--seed", "3", "--out", "d", "--name", "custom"});
  ASSERT_TRUE(defaults.has_value());
  EXPECT_EQ(defaults->worldSeed(), 3u);
  EXPECT_EQ(defaults->sequenceName(), "custom");
  EXPECT_EQ(defaults->static_start, 3.0);
  EXPECT_EQ(defaults->start_time, 1700000000.0);
  EXPECT_FALSE(defaults->lz4);
  EXPECT_EQ(defaults->image_format, "raw");
  EXPECT_FALSE(parseSimCommandLine({"--help"}).has_value());
}

TEST(SimCommandLine, ErrorsNameTheArgument) {
  const std::vector<std::string> base = {"--scenario", "tank", "--duration", "20", "--seed", "1", "--out", "d"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  EXPECT_NE(test::commandLineError({"--duration", "20", "--seed", "1", "--out", "d"}).find("--scenario"),
            std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--image-format", "bmp"})).find("--image-format: expected raw, png or jpeg"),
            std::string::npos)
      << test::commandLineError(with({"--image-format", "bmp"}));
  EXPECT_NE(test::commandLineError({"--scenario", "tank", "--seed", "1", "--out", "d"}).find("--duration"),
            std::string::npos);
  EXPECT_NE(test::commandLineError({"--scenario", "tank", "--duration", "5", "--out", "d"}).find("--seed"),
            std::string::npos);
  EXPECT_NE(test::commandLineError({"--scenario", "tank", "--duration", "5", "--seed", "1"}).find("--out"),
            std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--scenario", "lake"})).find("--scenario"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--duration", "abc"})).find("--duration"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--duration", "-3"})).find("--duration"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--seed", "-1"})).find("--seed"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--camera-off", "5"})).find("--camera-off"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--imu-gap", "6:5"})).find("--imu-gap"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--mag-off", "x:5"})).find("--mag-off"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--static-start", "25"})).find("--static-start"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--camera-delay", "2"})).find("--camera-delay"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--bogus", "1"})).find("--bogus"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--world-seed"})).find("--world-seed"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"stray"})).find("stray"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--magnetic-anomaly-ut", "-1"})).find("--magnetic-anomaly-ut"),
            std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--thruster-line-nt", "100"})).find("--thruster-line-nt: needs --thrusters"),
            std::string::npos);
  EXPECT_NE(
      test::commandLineError(with({"--thrusters", "--thruster-hard-iron-ut", "-2"})).find("--thruster-hard-iron-ut"),
      std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--coil-frequency-drift-hz", "3"})).find("--coil-frequency-drift-hz"),
            std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--coil-frequency", "2.5", "--coil-frequency-drift-hz", "-1"}))
                .find("--coil-frequency-drift-hz"),
            std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--magnetic-anomaly-width-m", "1"})).find("--magnetic-anomaly-width-m"),
            std::string::npos);
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
  // A repeat mission of the same vehicle (--rig-seed 1): b's path and noise with a's rig.
  SimOptions repeat = b;
  repeat.rig_seed = 1;
  const SimSetup sr = buildSimSetup(repeat);
  EXPECT_TRUE(sr.config.camera.T_b_c.isApprox(sa.config.camera.T_b_c, 0.0));
  EXPECT_EQ(sr.config.camera.fx, sa.config.camera.fx);
  EXPECT_TRUE(sr.config.magnetometer.T_b_m.isApprox(sa.config.magnetometer.T_b_m, 0.0));
  EXPECT_TRUE(sr.config.sonar.T_b_s.isApprox(sa.config.sonar.T_b_s, 0.0));
  EXPECT_EQ(sr.truth.gyro_bias, sb.truth.gyro_bias);  // the IMU's turn-on bias is the run's
  EXPECT_EQ(sr.truth.rig_seed, 1u);

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

namespace {

std::vector<std::string> withBase(std::vector<std::string> extra) {
  std::vector<std::string> args = {"--scenario", "tank", "--duration", "20", "--seed", "1", "--out", "d"};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

std::string setupErrorOf(const std::vector<std::string>& args) {
  try {
    buildSimSetup(*parseSimCommandLine(args));
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SimCommandLine, TerrainPresetsAndOverrides) {
  const auto defaults = parseSimCommandLine(withBase({}));
  ASSERT_TRUE(defaults.has_value());
  EXPECT_EQ(defaults->terrain.preset, "flat");
  EXPECT_FALSE(defaults->depth_hold_z.has_value());
  EXPECT_FALSE(defaults->pressure.enabled);
  EXPECT_TRUE(resolveTerrain(defaults->terrain, 1).isFlat());

  const TerrainParams slope4 = terrainFromOptions(parseSimCommandLine(withBase({"--terrain", "slope4"}))->terrain);
  EXPECT_EQ(slope4.slope_deg, 4.0);
  EXPECT_EQ(slope4.relief_m, 0.25);
  EXPECT_EQ(slope4.relief_wavelength_m, 30.0);
  EXPECT_EQ(slope4.roughness_m, 0.02);
  EXPECT_EQ(slope4.rock_height_m * slope4.rock_density, 0.0);
  const TerrainParams rough = terrainPreset("rough");
  EXPECT_EQ(rough.slope_deg, 2.0);
  EXPECT_EQ(rough.roughness_m, 0.1);
  EXPECT_EQ(rough.rock_height_m, 0.3);
  EXPECT_GT(rough.rock_density, 0.0);
  EXPECT_GT(terrainPreset("hills").relief_m, 0.5);
  EXPECT_THROW(terrainPreset("moon"), std::invalid_argument);

  const auto overridden = parseSimCommandLine(withBase({"--terrain",
                                                        "rough",
                                                        "--terrain-slope-deg",
                                                        "6.5",
                                                        "--terrain-slope-azimuth-deg",
                                                        "270",
                                                        "--terrain-relief-m",
                                                        "0.4",
                                                        "--terrain-relief-wavelength-m",
                                                        "22",
                                                        "--terrain-roughness-m",
                                                        "0.05",
                                                        "--terrain-rock-height-m",
                                                        "0.2",
                                                        "--terrain-rock-density",
                                                        "0.02",
                                                        "--depth-hold",
                                                        "4.5",
                                                        "--pressure",
                                                        "--pressure-rate-hz",
                                                        "20",
                                                        "--pressure-atmospheric-error-pa",
                                                        "-300",
                                                        "--pressure-spikes",
                                                        "0.01",
                                                        "--pressure-off",
                                                        "3:4"}));
  ASSERT_TRUE(overridden.has_value());
  const TerrainParams t = resolveTerrain(overridden->terrain, 17);
  EXPECT_EQ(t.slope_deg, 6.5);
  EXPECT_EQ(t.slope_azimuth_deg, 270.0);
  EXPECT_EQ(t.relief_m, 0.4);
  EXPECT_EQ(t.relief_wavelength_m, 22.0);
  EXPECT_EQ(t.roughness_m, 0.05);
  EXPECT_EQ(t.rock_height_m, 0.2);
  EXPECT_EQ(t.rock_density, 0.02);
  EXPECT_EQ(*overridden->depth_hold_z, 4.5);
  EXPECT_TRUE(overridden->pressure.enabled);
  EXPECT_EQ(overridden->pressure.rate_hz, 20.0);
  EXPECT_EQ(overridden->pressure.atmospheric_error_pa, -300.0);
  EXPECT_EQ(overridden->pressure.spike_fraction, 0.01);
  ASSERT_EQ(overridden->spans.pressure_off.size(), 1u);
  // A single override on the flat preset; the azimuth is then seeded by the world seed.
  const auto sloped = parseSimCommandLine(withBase({"--terrain-slope-deg", "3"}));
  const TerrainParams a = resolveTerrain(sloped->terrain, 1), b = resolveTerrain(sloped->terrain, 1),
                      c = resolveTerrain(sloped->terrain, 2);
  EXPECT_EQ(a.slope_deg, 3.0);
  EXPECT_EQ(a.relief_m, 0.0);
  EXPECT_EQ(a.slope_azimuth_deg, b.slope_azimuth_deg);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_NE(a.slope_azimuth_deg, c.slope_azimuth_deg);
  EXPECT_NE(a.seed, c.seed);
  EXPECT_GE(a.slope_azimuth_deg, 0.0);
  EXPECT_LT(a.slope_azimuth_deg, 360.0);
  EXPECT_TRUE(parseSimCommandLine(withBase({"--terrain", "hills", "--altitude-hold"})).has_value());
  EXPECT_FALSE(defaults->hold_plane_only);
  EXPECT_FALSE(defaults->sonar_max_range.has_value());
  const auto plane_only =
      parseSimCommandLine(withBase({"--terrain", "slope4", "--hold-plane-only", "--sonar-max-range", "4.2"}));
  ASSERT_TRUE(plane_only.has_value());
  EXPECT_TRUE(plane_only->hold_plane_only);
  EXPECT_EQ(*plane_only->sonar_max_range, 4.2);
  // The range limit is the YAML's max_range; the plane-only hold is a truth key.
  const SimSetup setup = buildSimSetup(*plane_only);
  EXPECT_EQ(setup.config.sonar.max_range, 4.2);
  EXPECT_TRUE(setup.truth.hold_plane_only);
  EXPECT_NE(setup.truth.toYaml().find("hold_plane_only: true"), std::string::npos);
  EXPECT_EQ(buildSimSetup(*defaults).truth.toYaml().find("hold_plane_only"), std::string::npos);
}

TEST(SimCommandLine, TerrainAndPressureErrorsNameTheFlag) {
  auto expectError = [](const std::vector<std::string>& extra, const std::string& flag) {
    const std::string error = test::commandLineError(withBase(extra));
    EXPECT_EQ(error.rfind(flag + ":", 0), 0u) << "'" << error << "' for " << extra.front();
  };
  expectError({"--terrain", "moon"}, "--terrain");
  expectError({"--terrain-slope-deg", "16"}, "--terrain-slope-deg");
  expectError({"--terrain-slope-deg", "-1"}, "--terrain-slope-deg");
  expectError({"--terrain-slope-azimuth-deg", "400"}, "--terrain-slope-azimuth-deg");
  expectError({"--terrain-relief-m", "3"}, "--terrain-relief-m");
  expectError({"--terrain-relief-wavelength-m", "1"}, "--terrain-relief-wavelength-m");
  expectError({"--terrain-roughness-m", "0.5"}, "--terrain-roughness-m");
  expectError({"--terrain-rock-height-m", "0.6"}, "--terrain-rock-height-m");
  expectError({"--terrain-rock-density", "0.5"}, "--terrain-rock-density");
  expectError({"--terrain-rock-density", "x"}, "--terrain-rock-density");
  expectError({"--depth-hold", "0.5"}, "--depth-hold");
  expectError({"--depth-hold", "4", "--altitude-hold"}, "--altitude-hold");
  expectError({"--altitude-hold", "--depth-hold", "4"}, "--depth-hold");
  expectError({"--depth-hold", "4", "--hold-plane-only"}, "--hold-plane-only");
  expectError({"--hold-plane-only", "--depth-hold", "4"}, "--depth-hold");
  expectError({"--sonar-max-range", "0.5"}, "--sonar-max-range");
  expectError({"--sonar-max-range", "200"}, "--sonar-max-range");
  expectError({"--pressure-rate-hz", "20"}, "--pressure-rate-hz");  // without --pressure
  expectError({"--pressure-spikes", "0.1"}, "--pressure-spikes");
  expectError({"--pressure-atmospheric-error-pa", "100"}, "--pressure-atmospheric-error-pa");
  expectError({"--pressure-off", "1:2"}, "--pressure-off");
  expectError({"--pressure", "--pressure-rate-hz", "0.5"}, "--pressure-rate-hz");
  expectError({"--pressure", "--pressure-rate-hz", "60"}, "--pressure-rate-hz");
  expectError({"--pressure", "--pressure-spikes", "0.9"}, "--pressure-spikes");
  expectError({"--pressure", "--pressure-atmospheric-error-pa", "5e4"}, "--pressure-atmospheric-error-pa");
  // The set-up checks the designed trajectory: a depth hold that meets the sloping seabed, one
  // that leaves the water.
  const std::string too_low = setupErrorOf({"--scenario", "field", "--duration", "300", "--seed", "1", "--out", "d",
                                            "--terrain", "slope4", "--depth-hold", "2"});
  EXPECT_EQ(too_low.rfind("--depth-hold: the designed altitude falls to", 0), 0u) << too_low;
  const std::string above = setupErrorOf(withBase({"--pressure", "--depth-hold", "12"}));
  EXPECT_EQ(above.rfind("--depth-hold: the pressure port reaches the water surface", 0), 0u) << above;
  EXPECT_EQ(setupErrorOf(withBase({"--terrain", "rough", "--depth-hold", "4", "--pressure"})), "");
}

TEST(SimTruth, TerrainAndPressureRoundTripAndRebuildTheSeabed) {
  SimOptions options;
  options.scenario = Scenario::kTank;
  options.duration = 30;
  options.seed = 3;
  options.world_seed = 8;
  options.out_dir = "/tmp/x/terrain";
  options.terrain.preset = "rough";
  options.depth_hold_z = 4.25;
  options.hold_plane_only = true;  // not a combination the command line allows, but every key round-trips
  options.pressure.enabled = true;
  options.pressure.atmospheric_error_pa = 250.0;
  options.pressure.spike_fraction = 0.02;
  options.spans.pressure_off = {{5.0, 7.5}};
  const SimSetup setup = buildSimSetup(options);
  const SimTruth& truth = setup.truth;
  const SimTruth loaded = savedAndLoaded(truth, "vims_truth_terrain");
  EXPECT_EQ(loaded.toYaml(), truth.toYaml());
  EXPECT_EQ(loaded.terrain.seed, setup.terrain->params().seed);
  EXPECT_EQ(loaded.terrain.slope_azimuth_deg, setup.terrain->params().slope_azimuth_deg);
  EXPECT_EQ(loaded.terrain.rock_density, 0.05);
  ASSERT_TRUE(loaded.depth_hold_z.has_value());
  EXPECT_EQ(*loaded.depth_hold_z, 4.25);
  EXPECT_TRUE(loaded.hold_plane_only);
  ASSERT_TRUE(loaded.pressure.has_value());
  EXPECT_EQ(loaded.pressure->water.surface_z, truth.pressure->water.surface_z);
  EXPECT_GE(loaded.pressure->water.surface_z, 9.0);
  EXPECT_LE(loaded.pressure->water.surface_z, 11.0);
  EXPECT_EQ(loaded.pressure->water.atmospheric_pa, 101325.0);
  EXPECT_EQ(loaded.pressure->water.density, 1000.0);  // the tank: fresh water
  EXPECT_EQ(loaded.pressure->atmospheric_error_pa, 250.0);
  EXPECT_EQ(loaded.pressure->spike_fraction, 0.02);
  ASSERT_EQ(loaded.dropouts.pressure_off.size(), 1u);
  EXPECT_EQ(loaded.dropouts.pressure_off[0].end, 7.5);
  // The coil lies on the terrain.
  EXPECT_EQ(truth.coil.position_w.z(), setup.terrain->height(truth.coil.position_w.x(), truth.coil.position_w.y()));
  // The evaluation's rebuilt seabed is the simulator's.
  const SeabedTerrain rebuilt = terrainFromTruth(loaded);
  for (double x = -10; x <= 10; x += 0.37) {
    for (double y = -10; y <= 10; y += 0.41) ASSERT_EQ(rebuilt.height(x, y), setup.terrain->height(x, y));
  }
  // The sequence YAML has the calibration only: no terrain, no surface.
  const std::string yaml = setup.config.toYaml();
  EXPECT_EQ(yaml.find("terrain"), std::string::npos);
  EXPECT_EQ(yaml.find("surface"), std::string::npos);
  EXPECT_NE(yaml.find("pressure: /pressure"), std::string::npos);
  ASSERT_TRUE(setup.config.pressure.has_value());
  EXPECT_EQ(setup.config.pressure->atmospheric_pa, 101325.0 + 250.0);
}

TEST(SimTruth, FilesWithoutTheNewKeysAreFlatAndBadTerrainIsRejected) {
  SimOptions options;
  options.duration = 10;
  options.seed = 1;
  options.out_dir = "/tmp/x/seq_flat";
  const std::string flat_yaml = buildSimSetup(options).truth.toYaml();
  for (const char* key : {"terrain", "pressure", "depth_hold_z", "surface"}) {
    EXPECT_EQ(flat_yaml.find(key), std::string::npos) << key;  // the file of a flat sequence is as it always was
  }
  const fs::path path = tempPath("vims_truth_old") += ".yaml";
  auto write = [&](const std::string& text) {
    std::ofstream out(path);
    out << text;
  };
  write(flat_yaml);
  const SimTruth old = SimTruth::load(path.string());
  EXPECT_TRUE(old.terrain.isFlat());
  EXPECT_TRUE(terrainFromTruth(old).isFlat());
  EXPECT_FALSE(old.pressure.has_value());
  EXPECT_FALSE(old.depth_hold_z.has_value());

  options.terrain.preset = "slope4";
  const std::string terrain_yaml = buildSimSetup(options).truth.toYaml();
  auto expectError = [&](const std::string& text, const std::string& key) {
    write(text);
    try {
      SimTruth::load(path.string());
      ADD_FAILURE() << "no error for " << key;
    } catch (const vims::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  };
  std::string extra_key = terrain_yaml;
  extra_key.replace(extra_key.find("  slope_deg:"), 0, "  colour: brown\n");
  expectError(extra_key, "colour");
  std::string wrong_wave = terrain_yaml;
  wrong_wave.replace(wrong_wave.find("relief_m: 0.25"), 14, "relief_m: 0.26");
  expectError(wrong_wave, "terrain.relief_waves");
  fs::remove(path);
}

TEST(SimSetup, PressureSensorFollowsTheContractAndLeavesTheRigAlone) {
  SimOptions options;
  options.scenario = Scenario::kField;
  options.duration = 30;
  options.seed = 8;
  options.out_dir = "/tmp/x/p";
  const SimSetup plain = buildSimSetup(options);
  options.pressure.enabled = true;
  const SimSetup with_pressure = buildSimSetup(options);
  EXPECT_FALSE(plain.config.pressure.has_value());
  ASSERT_TRUE(with_pressure.config.pressure.has_value());
  // Adding the sensor changes no other calibration and no other truth.
  vims::SequenceConfig without = with_pressure.config;
  without.pressure.reset();
  EXPECT_EQ(without.toYaml(), plain.config.toYaml());
  EXPECT_EQ(with_pressure.truth.coil.position_w, plain.truth.coil.position_w);
  EXPECT_EQ(with_pressure.truth.gyro_bias, plain.truth.gyro_bias);

  const fs::path path = tempPath("vims_seq_pressure") += ".yaml";
  with_pressure.config.save(path.string());
  std::vector<std::string> unknown;
  const vims::SequenceConfig loaded = vims::SequenceConfig::load(path.string(), &unknown);
  fs::remove(path);
  EXPECT_TRUE(unknown.empty());
  ASSERT_TRUE(loaded.pressure.has_value());
  const vims::PressureCalibration& p = *loaded.pressure;
  EXPECT_EQ(loaded.topics.pressure, "/pressure");
  EXPECT_EQ(p.rate_hz, 10.0);
  EXPECT_EQ(p.noise_std_pa, 80.0);
  EXPECT_EQ(p.atmospheric_pa, 101325.0);
  EXPECT_EQ(p.water_density, 1025.0);  // the field: sea water
  EXPECT_LT((p.T_b_p.linear() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_LT((p.T_b_p.translation() - Eigen::Vector3d(-0.30, 0.0, 0.10)).cwiseAbs().maxCoeff(), 0.031);
  EXPECT_GE(with_pressure.truth.pressure->water.surface_z, 27.0);
  EXPECT_LE(with_pressure.truth.pressure->water.surface_z, 33.0);
}

namespace vims {
namespace sim {
namespace {

TEST(SimSetup, ACameraExtrinsicErrorIsInTheYamlAndTheTruthKeepsTheTrueOne) {
  SimOptions options;
  options.duration = 30;
  options.seed = 4;
  options.out_dir = "/tmp/x/calib";
  const SimSetup exact = buildSimSetup(options);
  options.camera_extrinsic_error_deg = 1.0;
  options.camera_extrinsic_error_m = 0.01;
  const SimSetup off = buildSimSetup(options);
  ASSERT_TRUE(off.truth.camera_extrinsic_error.has_value());
  EXPECT_FALSE(exact.truth.camera_extrinsic_error.has_value());
  const Eigen::Isometry3d& truth = off.truth.camera_extrinsic_error->true_T_b_c;
  EXPECT_TRUE(truth.isApprox(exact.config.camera.T_b_c, 1e-15));  // the rig is the same
  EXPECT_TRUE(off.truth.trueCameraExtrinsic(off.config.camera.T_b_c).isApprox(truth, 1e-15));
  const double angle = Eigen::AngleAxisd(truth.linear().transpose() * off.config.camera.T_b_c.linear()).angle();
  EXPECT_NEAR(angle * 180.0 / M_PI, 1.0, 1e-9);
  EXPECT_NEAR((off.config.camera.T_b_c.translation() - truth.translation()).norm(), 0.01, 1e-12);
  // Nothing else of the sequence changes, and the truth file keeps the error.
  EXPECT_TRUE(off.config.sonar.T_b_s.isApprox(exact.config.sonar.T_b_s, 0.0));
  const SimTruth loaded = savedAndLoaded(off.truth, "vims_truth_calib");
  ASSERT_TRUE(loaded.camera_extrinsic_error.has_value());
  EXPECT_EQ(loaded.camera_extrinsic_error->rotation_deg, 1.0);
  EXPECT_EQ(loaded.camera_extrinsic_error->translation_m, 0.01);
  EXPECT_TRUE(loaded.camera_extrinsic_error->true_T_b_c.isApprox(truth, 1e-15));
}

TEST(SimSetup, AMagneticAnomalyLiesUnderTheMidMissionPositionAndTheTruthKeepsIt) {
  const auto options =
      parseSimCommandLine({"--scenario", "tank", "--duration", "40", "--seed", "2", "--out", "/tmp/x/anomaly",
                           "--magnetic-anomaly-ut", "2", "--magnetic-anomaly-width-m", "8"});
  ASSERT_TRUE(options.has_value());
  const SimSetup setup = buildSimSetup(*options);
  SimOptions clean = *options;
  clean.magnetic_anomaly_ut = 0.0;
  EXPECT_FALSE(buildSimSetup(clean).truth.magnetic_anomaly.has_value());
  ASSERT_TRUE(setup.truth.magnetic_anomaly.has_value());
  const MagneticAnomaly& anomaly = *setup.truth.magnetic_anomaly;
  const Eigen::Vector3d above = setup.trajectory.pose(3.0 + 0.5 * (40.0 - 3.0)).translation();
  EXPECT_LT((anomaly.position_w - (above - Eigen::Vector3d(0, 0, 4.0))).norm(), 1e-12);
  EXPECT_NEAR(anomaly.field(above).norm(), 2e-6, 1e-12);
  // The magnetometer measures it: the world's field at that point is the site's plus the anomaly's.
  const MagneticWorld world = setup.truth.magneticWorld();
  EXPECT_LT((world.fieldEnu(above, 0.0) - world.coil.field(above, 0.0) - setup.truth.geomagnetic.fieldEnu() -
             anomaly.field(above))
                .norm(),
            1e-15);
  const SimTruth loaded = savedAndLoaded(setup.truth, "vims_truth_anomaly");
  EXPECT_EQ(loaded.coil.frequency_rate, 0.0);
  ASSERT_TRUE(loaded.magnetic_anomaly.has_value());
  EXPECT_LT((loaded.magnetic_anomaly->position_w - anomaly.position_w).norm(), 1e-9);
  EXPECT_LT((loaded.magnetic_anomaly->moment_enu - anomaly.moment_enu).norm(), 1e-9 * anomaly.moment_enu.norm());
}

}  // namespace
}  // namespace sim
}  // namespace vims

namespace vims {
namespace sim {
namespace {

TEST(SimSetup, ADriftingCoilStatesItsStartFrequencyAndTheTruthKeepsTheRate) {
  const auto options = parseSimCommandLine({"--scenario", "tank", "--duration", "200", "--seed", "2", "--out",
                                            "/tmp/x/drift", "--coil-frequency-drift-hz", "0.1"});
  ASSERT_TRUE(options.has_value());
  const SimSetup setup = buildSimSetup(*options);
  EXPECT_EQ(setup.config.magnetometer.coil_frequency_hz, 11.0);
  EXPECT_NEAR(setup.truth.coil.frequency_rate, 0.1 / 200.0, 1e-15);
  const SimTruth loaded = savedAndLoaded(setup.truth, "vims_truth_drift");
  EXPECT_EQ(loaded.coil.frequency_rate, setup.truth.coil.frequency_rate);
}

}  // namespace
}  // namespace sim
}  // namespace vims

namespace vims {
namespace sim {
namespace {

TEST(SimSetup, ThrustersAreSeededByTheRigAndTheTruthKeepsThem) {
  const auto options =
      parseSimCommandLine({"--scenario", "tank", "--duration", "40", "--seed", "2", "--out", "/tmp/x/thrusters",
                           "--thrusters", "--thruster-line-hz", "30", "--thruster-hard-iron-ut", "2"});
  ASSERT_TRUE(options.has_value());
  const SimSetup setup = buildSimSetup(*options);
  ASSERT_TRUE(setup.truth.thrusters.has_value());
  const ThrusterInterference& th = *setup.truth.thrusters;
  EXPECT_EQ(th.line_frequency_hz, 30.0);
  EXPECT_NEAR(th.hard_iron_tesla, 2e-6, 1e-18);
  EXPECT_NEAR(th.hard_iron_direction_m.norm(), 1.0, 1e-12);
  EXPECT_GT((th.line_direction_m[0] - th.line_direction_m[1]).norm(), 1e-3);
  const SimTruth loaded = savedAndLoaded(setup.truth, "vims_truth_thrusters");
  ASSERT_TRUE(loaded.thrusters.has_value());
  EXPECT_EQ(loaded.thrusters->line_frequency_hz, 30.0);
  EXPECT_LT((loaded.thrusters->hard_iron_direction_m - th.hard_iron_direction_m).norm(), 1e-12);
  EXPECT_LT((loaded.thrusters->line_direction_m[1] - th.line_direction_m[1]).norm(), 1e-12);
}

}  // namespace
}  // namespace sim
}  // namespace vims

namespace vims {
namespace sim {
namespace {

TEST(SimSetup, MagnetometerIronIsSeededByTheRigMeasuredAndKeptInTheTruthOnly) {
  const auto options = parseSimCommandLine({"--scenario", "tank", "--duration", "40", "--seed", "2", "--out",
                                            "/tmp/x/iron", "--mag-hard-iron-ut", "5", "--mag-soft-iron-pct", "5"});
  ASSERT_TRUE(options.has_value());
  const SimSetup setup = buildSimSetup(*options);
  ASSERT_TRUE(setup.truth.magnetometer_iron.has_value());
  const MagnetometerIron& iron = *setup.truth.magnetometer_iron;
  EXPECT_NEAR(iron.hard_iron_t.norm(), 5e-6, 1e-18);
  // Symmetric, gains 1.05, 0.95 and one within [0.95, 1.05].
  EXPECT_LT((iron.soft_iron - iron.soft_iron.transpose()).cwiseAbs().maxCoeff(), 1e-15);
  const Eigen::Vector3d gains = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(iron.soft_iron).eigenvalues();
  EXPECT_NEAR(gains[0], 0.95, 1e-12);
  EXPECT_NEAR(gains[2], 1.05, 1e-12);
  EXPECT_GE(gains[1], 0.95 - 1e-12);
  EXPECT_LE(gains[1], 1.05 + 1e-12);
  const SimTruth loaded = savedAndLoaded(setup.truth, "vims_truth_iron");
  ASSERT_TRUE(loaded.magnetometer_iron.has_value());
  EXPECT_LT((loaded.magnetometer_iron->hard_iron_t - iron.hard_iron_t).norm(), 1e-18);
  EXPECT_LT((loaded.magnetometer_iron->soft_iron - iron.soft_iron).cwiseAbs().maxCoeff(), 1e-12);

  // The magnetometer measures W h + b for the outside field h (noise-free here).
  MagnetometerParams quiet;
  quiet.noise_std = 0.0;
  MagnetometerSimulator clean(quiet, Eigen::Isometry3d::Identity(), setup.truth.magneticWorld(), 1);
  MagnetometerSimulator ironed(quiet, Eigen::Isometry3d::Identity(), setup.truth.magneticWorld(), 1);
  ironed.setIron(iron);
  const Eigen::Isometry3d pose = setup.trajectory.pose(20.0);
  const Eigen::Vector3d h = clean.measure(pose, 20.0);
  EXPECT_LT((ironed.measure(pose, 20.0) - (iron.soft_iron * h + iron.hard_iron_t)).norm(), 1e-15);

  // Without the options: no iron (and the option's range is checked).
  const auto plain =
      parseSimCommandLine({"--scenario", "tank", "--duration", "40", "--seed", "2", "--out", "/tmp/x/plain"});
  EXPECT_FALSE(buildSimSetup(*plain).truth.magnetometer_iron.has_value());
  EXPECT_THROW(
      parseSimCommandLine({"--scenario", "tank", "--seed", "2", "--out", "/tmp/x/bad", "--mag-soft-iron-pct", "30"}),
      std::invalid_argument);
}

}  // namespace
}  // namespace sim
}  // namespace vims

TEST(SimCommandLine, RepeatMissionConditionsParseReachTheSetUpAndTheTruthOnly) {
  const std::vector<std::string> base = {"--scenario", "tank", "--duration", "20", "--seed", "4", "--out", "d"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  const auto options = parseSimCommandLine(
      with({"--start-along-lap-m", "40", "--reverse-lap", "--altitude-offset-m", "1.5", "--turbidity", "3",
            "--lamp-power", "0.5", "--seabed-change", "0.2", "--world-seed", "3", "--rig-seed", "3"}));
  ASSERT_TRUE(options.has_value());
  EXPECT_EQ(options->mission.start_along_lap_m, 40.0);
  EXPECT_TRUE(options->mission.reverse_lap);
  EXPECT_EQ(options->mission.altitude_offset_m, 1.5);
  EXPECT_EQ(options->mission.turbidity, 3.0);
  EXPECT_EQ(options->mission.lamp_power, 0.5);
  EXPECT_EQ(options->mission.seabed_change, 0.2);

  const SimSetup setup = buildSimSetup(*options);
  const UnderwaterOptics clear;
  EXPECT_DOUBLE_EQ(setup.optics.attenuation, 3.0 * clear.attenuation);
  EXPECT_DOUBLE_EQ(setup.optics.backscatter_range, clear.backscatter_range / 3.0);
  EXPECT_EQ(setup.optics.reference_attenuation, clear.reference_attenuation);  // the exposure stays
  EXPECT_EQ(setup.optics.lamp_power, 0.5);
  EXPECT_EQ(setup.texture.change_fraction, 0.2);
  // The sequence YAML does not say any of it; the truth file does, and reads back.
  SimOptions plain = *options;
  plain.mission = MissionConditions();
  EXPECT_EQ(setup.config.toYaml(), buildSimSetup(plain).config.toYaml());
  EXPECT_EQ(buildSimSetup(plain).truth.toYaml().find("mission:"), std::string::npos);
  const SimTruth loaded = savedAndLoaded(setup.truth, "vims_truth_mission");
  EXPECT_EQ(loaded.mission.start_along_lap_m, 40.0);
  EXPECT_TRUE(loaded.mission.reverse_lap);
  EXPECT_EQ(loaded.mission.seabed_change, 0.2);
  EXPECT_EQ(loaded.toYaml(), setup.truth.toYaml());

  EXPECT_NE(test::commandLineError(with({"--altitude-offset-m", "4"})).find("--altitude-offset-m"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--depth-hold", "5", "--altitude-offset-m", "1"})).find("--altitude-offset-m"),
            std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--turbidity", "0.5"})).find("--turbidity"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--lamp-power", "0"})).find("--lamp-power"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--seabed-change", "0.9"})).find("--seabed-change"), std::string::npos);
  EXPECT_NE(test::commandLineError(with({"--start-along-lap-m", "-1"})).find("--start-along-lap-m"), std::string::npos);
}
