// Several seabed coils (vims_sim --coil-frequencies, --coil-spacing): option parsing and
// validation, placement on the base lap, the truth round trip, the sequence YAML, and that a
// sequence without the option is the one of before.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "vims_common/config_reader.h"
#include "vims_common/sequence_config.h"
#include "vims_sim/sim_options.h"
#include "vims_sim/sim_setup.h"
#include "vims_sim/sim_truth.h"

namespace vims {
namespace sim {
namespace {

namespace fs = std::filesystem;

fs::path tempPath(const std::string& stem) {
  return fs::temp_directory_path() / (stem + "_" + std::to_string(::getpid()) + "_" +
                                      ::testing::UnitTest::GetInstance()->current_test_info()->name());
}

std::string errorOf(std::vector<std::string> extra, const std::string& scenario = "field") {
  std::vector<std::string> args = {"--scenario", scenario, "--duration", "30", "--seed", "1", "--out", "/tmp/x/coils"};
  args.insert(args.end(), extra.begin(), extra.end());
  try {
    parseSimCommandLine(args);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

SimOptions parsed(std::vector<std::string> extra, const std::string& scenario = "field") {
  std::vector<std::string> args = {"--scenario", scenario, "--duration", "30", "--seed", "1", "--out", "/tmp/x/coils"};
  args.insert(args.end(), extra.begin(), extra.end());
  return *parseSimCommandLine(args);
}

/// Distance from p to the closed base lap of the scenario.
double distanceToLap(Scenario scenario, const Eigen::Vector2d& p) {
  const auto lap = scenarioLapWaypoints(scenario);
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < lap.size(); ++i) {
    const Eigen::Vector2d a = lap[i], d = lap[(i + 1) % lap.size()] - lap[i];
    const double s = std::max(0.0, std::min(1.0, (p - a).dot(d) / d.squaredNorm()));
    best = std::min(best, (a + s * d - p).norm());
  }
  return best;
}

double horizontal(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).head<2>().norm(); }

TEST(SimCoils, ParsesTheFrequencyListAndTheSpacing) {
  const SimOptions one = parsed({});
  EXPECT_TRUE(one.other_coil_frequencies_hz.empty());
  EXPECT_EQ(one.coil_spacing_m, 30.0);
  const SimOptions two = parsed({"--coil-frequencies", "11,17"});
  EXPECT_EQ(two.coil_frequency_hz, 11.0);
  EXPECT_EQ(two.other_coil_frequencies_hz, std::vector<double>({17.0}));
  const SimOptions three = parsed({"--coil-frequencies", "13.5,7,21.25", "--coil-spacing", "25"});
  EXPECT_EQ(three.coil_frequency_hz, 13.5);
  EXPECT_EQ(three.other_coil_frequencies_hz, std::vector<double>({7.0, 21.25}));
  EXPECT_EQ(three.coil_spacing_m, 25.0);
  // The same drift in hertz for every coil.
  const SimOptions drift = parsed({"--coil-frequencies", "11,17", "--coil-frequency-drift-hz", "0.2"});
  EXPECT_EQ(drift.coil_frequency_drift_hz, 0.2);
}

TEST(SimCoils, RejectsBadListsAndConflictingOptions) {
  const auto has = [](const std::string& error, const std::string& part) {
    return error.find(part) != std::string::npos;
  };
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11"}), "--coil-frequencies: expected two or more"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,"}), "--coil-frequencies: expected a number"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,abc"}), "--coil-frequencies: expected a number, got 'abc'"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,250"}), "--coil-frequencies: must be in [2, 200] Hz"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "1.5,11"}), "--coil-frequencies: must be in [2, 200] Hz"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,11.5"}), "--coil-frequencies: 11 Hz and 11.5 Hz are closer"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,17,16.2"}), "17 Hz and 16.2 Hz are closer than 1 Hz"));
  EXPECT_EQ(errorOf({"--coil-frequencies", "11,12"}), "");  // exactly 1 Hz apart
  EXPECT_TRUE(has(errorOf({"--mag-rate-hz", "200", "--coil-frequencies", "11,95"}),
                  "--coil-frequencies: 95 Hz must be below 0.45 x the magnetometer's rate"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "3,6,9,12,15,18,21,24,27"}), "--coil-frequencies: at most 8 coils"));
  EXPECT_EQ(errorOf({"--coil-frequencies", "3,6,9,12,15,18,21,24"}), "");
  // Mutually exclusive with --coil-frequency (either order) and --coil-frequency-unknown.
  EXPECT_TRUE(has(errorOf({"--coil-frequency", "11", "--coil-frequencies", "11,17"}),
                  "--coil-frequencies: conflicts with --coil-frequency"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,17", "--coil-frequency", "11"}),
                  "--coil-frequency: conflicts with --coil-frequencies"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,17", "--coil-frequency-unknown"}),
                  "--coil-frequencies: conflicts with --coil-frequency-unknown"));
  EXPECT_TRUE(has(errorOf({"--coil-frequency-unknown", "--coil-frequencies", "11,17"}),
                  "--coil-frequencies: conflicts with --coil-frequency-unknown"));
  // The spacing needs several coils and a sensible value.
  EXPECT_TRUE(has(errorOf({"--coil-spacing", "20"}), "--coil-spacing: needs --coil-frequencies"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,17", "--coil-spacing", "0.5"}), "--coil-spacing: must be in"));
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,17", "--coil-spacing", "x"}), "--coil-spacing: expected"));
  // The drift must keep every coil in range.
  EXPECT_TRUE(has(errorOf({"--coil-frequencies", "11,2.5", "--coil-frequency-drift-hz", "-1"}),
                  "--coil-frequency-drift-hz: takes the 2.5 Hz coil's frequency out of"));
  EXPECT_EQ(errorOf({"--coil-frequencies", "11,2.5", "--coil-frequency-drift-hz", "0.4"}), "");
}

TEST(SimCoils, FurtherCoilsLieOnTheLapAtTheSpacingFromTheFirst) {
  for (const uint64_t world_seed : {1u, 2u, 3u, 17u}) {
    SimOptions options = parsed({"--coil-frequencies", "11,17,23"});
    options.world_seed = world_seed;
    const SimSetup setup = buildSimSetup(options);
    const SimTruth& truth = setup.truth;
    ASSERT_EQ(truth.other_coils.size(), 2u);
    for (const CoilDipole& other : truth.other_coils) {
      EXPECT_NEAR(horizontal(other.position_w, truth.coil.position_w), 30.0, 1e-6) << "world seed " << world_seed;
      EXPECT_LT(distanceToLap(Scenario::kField, other.position_w.head<2>()), 1e-9);
      EXPECT_EQ(other.position_w.z(), 0.0);  // the flat seabed
      EXPECT_LE(std::abs(other.position_w.x()), 39.0);
      EXPECT_LE(std::abs(other.position_w.y()), 29.0);
      // The first coil's hardware.
      EXPECT_EQ(other.turns, truth.coil.turns);
      EXPECT_EQ(other.current, truth.coil.current);
      EXPECT_EQ(other.diameter, truth.coil.diameter);
    }
    // The third coil keeps the spacing from the second as well (the field lap has room).
    EXPECT_GE(horizontal(truth.other_coils[1].position_w, truth.other_coils[0].position_w), 30.0 - 1e-6);
    EXPECT_EQ(truth.other_coils[0].frequency, 17.0);
    EXPECT_EQ(truth.other_coils[1].frequency, 23.0);
    // Own free-running phases.
    EXPECT_NE(truth.other_coils[0].phase, truth.coil.phase);
    EXPECT_NE(truth.other_coils[1].phase, truth.other_coils[0].phase);
  }
  // Another spacing.
  const SimSetup s20 = buildSimSetup(parsed({"--coil-frequencies", "11,17", "--coil-spacing", "20"}));
  EXPECT_NEAR(horizontal(s20.truth.other_coils[0].position_w, s20.truth.coil.position_w), 20.0, 1e-6);
}

TEST(SimCoils, PlacementFollowsTheWorldSeedAndPhasesTheTrajectorySeed) {
  SimOptions a = parsed({"--coil-frequencies", "11,17,23"});
  a.world_seed = 40;
  SimOptions b = a;
  b.seed = 2;  // another dive over the same site
  const SimSetup sa = buildSimSetup(a), sb = buildSimSetup(b), sa2 = buildSimSetup(a);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(sa.truth.other_coils[i].position_w, sb.truth.other_coils[i].position_w);
    EXPECT_EQ(sa.truth.other_coils[i].position_w, sa2.truth.other_coils[i].position_w);
    EXPECT_EQ(sa.truth.other_coils[i].phase, sa2.truth.other_coils[i].phase);
    EXPECT_NE(sa.truth.other_coils[i].phase, sb.truth.other_coils[i].phase);
  }
  // Coil n does not depend on how many coils follow it.
  SimOptions two = a;
  two.other_coil_frequencies_hz = {17.0};
  const SimSetup s2 = buildSimSetup(two);
  EXPECT_EQ(s2.truth.other_coils[0].position_w, sa.truth.other_coils[0].position_w);
  EXPECT_EQ(s2.truth.other_coils[0].phase, sa.truth.other_coils[0].phase);
  // The seed chooses between the lap's crossings of the circle: not every world seed the same side.
  bool differs = false;
  for (uint64_t w = 1; w <= 8 && !differs; ++w) {
    const auto p1 = placeOtherCoils(Scenario::kField, Eigen::Vector2d(0.0, -24.0), 1, 30.0, w);
    const auto p0 = placeOtherCoils(Scenario::kField, Eigen::Vector2d(0.0, -24.0), 1, 30.0, 0);
    differs = (p1[0] - p0[0]).norm() > 1.0;
  }
  EXPECT_TRUE(differs);
}

TEST(SimCoils, ASpacingBeyondTheLapGivesItsFarthestPointsAndTerrainLiftsTheCoils) {
  // The tank's lap is about 18 m across: 30 m is out of reach, so the second coil goes to the lap's
  // farthest point from the first and the third as far as possible from both.
  const SimSetup tank = buildSimSetup(parsed({"--coil-frequencies", "11,17,23"}, "tank"));
  const SimTruth& t = tank.truth;
  double farthest = 0.0;
  for (const Eigen::Vector2d& w : scenarioLapWaypoints(Scenario::kTank))
    farthest = std::max(farthest, (w - t.coil.position_w.head<2>()).norm());
  EXPECT_NEAR(horizontal(t.other_coils[0].position_w, t.coil.position_w), farthest, 1e-9);
  EXPECT_LT(farthest, 30.0);
  const double third_clearance = std::min(horizontal(t.other_coils[1].position_w, t.coil.position_w),
                                          horizontal(t.other_coils[1].position_w, t.other_coils[0].position_w));
  EXPECT_GT(third_clearance, 8.0);
  for (const CoilDipole& c : t.other_coils) EXPECT_LT(distanceToLap(Scenario::kTank, c.position_w.head<2>()), 1e-9);

  // On a sloping seabed every coil lies on the terrain.
  const SimSetup slope = buildSimSetup(parsed({"--coil-frequencies", "11,17", "--terrain", "slope4"}));
  const CoilDipole& other = slope.truth.other_coils[0];
  EXPECT_EQ(other.position_w.z(), slope.terrain->height(other.position_w.x(), other.position_w.y()));
  EXPECT_GT(std::abs(other.position_w.z()), 0.05);
  EXPECT_NEAR(horizontal(other.position_w, slope.truth.coil.position_w), 30.0, 1e-6);
}

TEST(SimCoils, TheYamlListsEveryFrequencyAndTheDriftIsCommon) {
  const SimSetup setup =
      buildSimSetup(parsed({"--coil-frequencies", "11,17", "--coil-frequency-drift-hz", "0.3", "--duration", "60"}));
  EXPECT_EQ(setup.config.magnetometer.coil_frequency_hz, 11.0);
  EXPECT_EQ(setup.config.magnetometer.other_coil_frequencies_hz, std::vector<double>({17.0}));
  const std::string yaml = setup.config.toYaml();
  EXPECT_NE(yaml.find("coil_frequency_hz: [11, 17]"), std::string::npos) << yaml;
  const SequenceConfig reloaded = SequenceConfig::fromReader(ConfigReader::fromString(yaml, "seq.yaml"));
  EXPECT_EQ(reloaded.magnetometer.coil_frequency_hz, 11.0);
  EXPECT_EQ(reloaded.magnetometer.other_coil_frequencies_hz, std::vector<double>({17.0}));
  EXPECT_NEAR(setup.truth.coil.frequency_rate, 0.3 / 60.0, 1e-15);
  EXPECT_EQ(setup.truth.other_coils[0].frequency_rate, setup.truth.coil.frequency_rate);
  // The magnetometer's world holds both coils.
  const MagneticWorld world = setup.truth.magneticWorld();
  ASSERT_EQ(world.other_coils.size(), 1u);
  const Eigen::Vector3d p = setup.truth.other_coils[0].position_w + Eigen::Vector3d(0.0, 0.0, 2.0);
  EXPECT_LT((world.fieldEnu(p, 1.3) - setup.truth.geomagnetic.fieldEnu() - setup.truth.coil.field(p, 1.3) -
             setup.truth.other_coils[0].field(p, 1.3))
                .norm(),
            1e-18);
}

TEST(SimCoils, TheTruthRoundTripsEveryCoilAndOlderFilesStillLoad) {
  const SimSetup setup = buildSimSetup(
      parsed({"--coil-frequencies", "11,17,23.5", "--coil-frequency-drift-hz", "0.1", "--terrain", "slope4"}));
  const std::string text = setup.truth.toYaml();
  EXPECT_NE(text.find("\nother_coils:"), std::string::npos);
  const fs::path path = tempPath("vims_truth_coils") += ".yaml";
  setup.truth.save(path.string());
  const SimTruth loaded = SimTruth::load(path.string());
  ASSERT_EQ(loaded.other_coils.size(), 2u);
  EXPECT_EQ(loaded.coilCount(), 3);
  for (int i = 0; i < 3; ++i) {
    const CoilDipole& a = *setup.truth.coilAt(i);
    const CoilDipole& b = *loaded.coilAt(i);
    EXPECT_EQ(b.position_w, a.position_w);
    EXPECT_EQ(b.turns, a.turns);
    EXPECT_EQ(b.current, a.current);
    EXPECT_EQ(b.diameter, a.diameter);
    EXPECT_EQ(b.frequency, a.frequency);
    EXPECT_EQ(b.frequency_rate, a.frequency_rate);
    EXPECT_EQ(b.phase, a.phase);
  }
  EXPECT_EQ(loaded.coilAt(3), nullptr);
  EXPECT_EQ(loaded.coilAt(-1), nullptr);
  EXPECT_EQ(loaded.toYaml(), text);

  // A further coil is validated like the first: the error names the item and the key.
  auto rewritten = [&](const std::string& from, const std::string& to) {
    std::string bad = text;
    const size_t at = bad.find(from, bad.find("\nother_coils:"));
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) bad.replace(at, from.size(), to);
    std::ofstream(path) << bad;
    try {
      SimTruth::load(path.string());
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(rewritten("turns: 330", "turns: 331").find("other_coils[0].moment_enu: inconsistent"), std::string::npos);
  EXPECT_NE(rewritten("frequency_hz: 23.5", "frequency_hz: -1").find("other_coils[1].frequency_hz"), std::string::npos);
  EXPECT_NE(rewritten("phase_rad:", "phase_radians:").find("other_coils[0]"), std::string::npos);
  {
    std::string bad = text;
    bad.replace(bad.find("\nother_coils:"), 13, "\nother_coils: 3");
    bad.erase(bad.find("other_coils: 3") + 14, bad.find("\ngeomagnetic:") - bad.find("other_coils: 3") - 14);
    std::ofstream(path) << bad;
    EXPECT_THROW(SimTruth::load(path.string()), ConfigError);
  }

  // A file of one coil (as every file before several coils existed) has no other_coils and loads.
  SimOptions single = parsed({});
  const std::string single_text = buildSimSetup(single).truth.toYaml();
  EXPECT_EQ(single_text.find("other_coils"), std::string::npos);
  std::ofstream(path) << single_text;
  const SimTruth one = SimTruth::load(path.string());
  EXPECT_TRUE(one.other_coils.empty());
  EXPECT_EQ(one.coilCount(), 1);
  fs::remove(path);
}

TEST(SimCoils, WithoutTheOptionTheSequenceIsUnchanged) {
  // The further coils draw from their own streams: the first coil, the rig, the biases and the
  // site are those of the sequence without them.
  for (const std::string scenario : {"field", "tank"}) {
    const SimSetup plain = buildSimSetup(parsed({"--coil-frequency", "11"}, scenario));
    const SimSetup multi = buildSimSetup(parsed({"--coil-frequencies", "11,17,29"}, scenario));
    EXPECT_TRUE(plain.truth.other_coils.empty());
    EXPECT_TRUE(plain.config.magnetometer.other_coil_frequencies_hz.empty());
    EXPECT_EQ(multi.truth.coil.position_w, plain.truth.coil.position_w);
    EXPECT_EQ(multi.truth.coil.phase, plain.truth.coil.phase);
    EXPECT_EQ(multi.truth.coil.frequency, plain.truth.coil.frequency);
    EXPECT_EQ(multi.truth.geomagnetic.fieldEnu(), plain.truth.geomagnetic.fieldEnu());
    EXPECT_EQ(multi.truth.gyro_bias, plain.truth.gyro_bias);
    EXPECT_EQ(multi.config.camera.T_b_c.matrix(), plain.config.camera.T_b_c.matrix());
    EXPECT_EQ(multi.config.magnetometer.T_b_m.matrix(), plain.config.magnetometer.T_b_m.matrix());
    // The one-coil YAML still states a single number.
    EXPECT_NE(plain.config.toYaml().find("coil_frequency_hz: 11\n"), std::string::npos);
    // The one-coil field is the first coil's alone.
    const Eigen::Vector3d p = plain.truth.coil.position_w + Eigen::Vector3d(1.0, 0.5, 2.0);
    EXPECT_EQ(plain.truth.magneticWorld().fieldEnu(p, 0.7),
              plain.truth.geomagnetic.fieldEnu() + plain.truth.coil.field(p, 0.7));
  }
}

}  // namespace
}  // namespace sim
}  // namespace vims
