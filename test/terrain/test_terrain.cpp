// The seabed model on terrain (issue 17): vims_offline on a simulated sloping field with a
// pressure sensor, with the seabed model local_plane (default) and horizontal (the paper's), with
// and without the pressure factor, and with bad pressure input. The figures of each run are
// printed; the bounds are about twice what the runs measure (docs/benchmarks.md, "Terrain"), so a
// regression fails.
//
// One executable, one CTest per case (test/terrain/CMakeLists.txt); the sequences are simulated by
// the fixtures at test time.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "vims_test/tool_runner.h"

namespace fs = std::filesystem;

namespace {

using vims::test::CommandResult;
using vims::test::runCommand;
using vims::test::summaryValues;

std::string tool(const std::string& name) { return std::string(VIMS_DEVEL_BIN_DIR) + "/" + name; }

struct RunFigures {
  CommandResult offline;
  double vio_pct = NAN;       ///< VIO translation ATE (SE3) in % of the distance
  double vio_tilt_deg = NAN;  ///< VIO tilt error rms after a yaw-only alignment
  double vio_rot_deg = NAN;
  double global_pct = NAN;
};

/// Runs vims_offline (VIO only unless `with_pose_graph`) on sequence `name` with the estimator
/// section `estimator_yaml`, then vims_eval on its outputs.
RunFigures runOn(const std::string& name, const std::string& label, const std::string& estimator_yaml,
                 bool with_pose_graph = false) {
  const fs::path sequence = vims::test::testSequence(name);
  const fs::path out = fs::path(vims::test::testSequence("terrain_runs")) / (name + "_" + label);
  fs::remove_all(out);
  fs::create_directories(out);
  const fs::path config = out / "config.yaml";
  std::ofstream(config) << "estimator:\n" << estimator_yaml;
  RunFigures f;
  f.offline = runCommand(tool("vims_offline") + " --quiet --sequence " + sequence.string() + " --out " + out.string() +
                         " --config " + config.string() + (with_pose_graph ? "" : " --vio-only"));
  std::ofstream(out / "offline.log") << f.offline.output;
  EXPECT_EQ(f.offline.exit_code, 0) << f.offline.output;
  const CommandResult eval =
      runCommand(tool("vims_eval") + " run --sequence " + sequence.string() + " --out " + out.string());
  const auto vio = summaryValues(eval.output, "VIMS_EVAL label=vio");
  if (vio.count("ate_se3_pct")) {
    f.vio_pct = std::stod(vio.at("ate_se3_pct"));
    f.vio_tilt_deg = std::stod(vio.at("tilt_rmse_deg"));
    f.vio_rot_deg = std::stod(vio.at("rot_rmse_deg"));
  } else {
    ADD_FAILURE() << "no VIO figures:\n" << eval.output;
  }
  const auto global = summaryValues(eval.output, "VIMS_EVAL label=global");
  if (global.count("ate_se3_pct")) f.global_pct = std::stod(global.at("ate_se3_pct"));
  std::cout << "[terrain] " << name << " " << label << ": VIO " << f.vio_pct << " % of distance, rot " << f.vio_rot_deg
            << " deg, tilt " << f.vio_tilt_deg << " deg; global " << f.global_pct << " %" << std::endl;
  return f;
}

// Bounds: about twice what the runs measure on the fixtures (120 s of the field, seed 3, 4 deg +
// 0.25 m relief): local_plane VIO 0.026 % of the distance, tilt 0.16 deg (the paper's horizontal
// seabed: 0.27 %, 1.76 deg); with the pressure factor 0.015 %, 0.053 deg, with the bad pressure
// input the same.
constexpr double kTiltBoundDeg = 0.35;
constexpr double kVioBoundPct = 0.06;
constexpr double kPressureTiltBoundDeg = 0.12;
constexpr double kPressureVioBoundPct = 0.03;

// The seabed beyond the sonar's range for about 70 of 200 s (terrain_dropoff): VIO 0.102 %, tilt
// 0.044 deg. Rocks under the beam (terrain_rocks, 120 s): VIO 0.035 %, tilt 0.059 deg. (The
// rotation RMSE is not bounded on these straight 120-200 s legs: a position-only SE3 fit of a
// nearly straight path leaves its roll free, the tilt after a yaw-only fit is the figure.)
constexpr double kDropoffVioBoundPct = 0.18;
constexpr double kDropoffTiltBoundDeg = 0.1;
constexpr double kRocksVioBoundPct = 0.07;
constexpr double kRocksTiltBoundDeg = 0.13;

const char* kLocalPlane = "  seabed: {model: local_plane}\n  pressure: {enabled: false}\n";
// The paper's seabed: level, every feature's sonar factor at full weight whatever its distance
// from the beam's spot (no growth, none learnt). (The level seabed with the misfit growth, the
// default weighting, is close to the local plane here: 0.033 % and 0.17 deg against 0.026 % and
// 0.16 deg.)
const char* kHorizontal =
    "  seabed: {model: horizontal}\n  pressure: {enabled: false}\n"
    "  factors: {sonar_depth: {misfit_per_m: 0.0, learn_misfit: false}}\n";
const char* kLocalPlanePressure = "  seabed: {model: local_plane}\n  pressure: {enabled: true}\n";

bool contains(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

}  // namespace

// On a 4 deg slope the paper's horizontal seabed tilts the attitude and biases the scale; the
// local plane follows the seabed.
TEST(Terrain, LocalPlaneFollowsASlopingSeabedThatTheHorizontalModelTilts) {
  const RunFigures plane = runOn("terrain_slope4", "local_plane", kLocalPlane);
  const RunFigures level = runOn("terrain_slope4", "horizontal", kHorizontal);
  EXPECT_LT(plane.vio_tilt_deg, 0.5 * level.vio_tilt_deg);
  EXPECT_LT(plane.vio_pct, level.vio_pct);
  EXPECT_LT(plane.vio_tilt_deg, kTiltBoundDeg);
  EXPECT_LT(plane.vio_pct, kVioBoundPct);
}

// The pressure factor with a wrong atmospheric offset in the YAML and spikes on the topic: the
// estimator says so and stays as accurate as with a clean pressure sensor.
TEST(Terrain, PressureWithAWrongOffsetAndSpikesIsHandled) {
  const RunFigures clean = runOn("terrain_slope4", "pressure", kLocalPlanePressure);
  const RunFigures bad = runOn("terrain_slope4_bad_pressure", "pressure", kLocalPlanePressure);
  EXPECT_TRUE(contains(bad.offline.output, "spike")) << bad.offline.output;
  EXPECT_LT(bad.vio_pct, 1.5 * clean.vio_pct);
  EXPECT_LT(bad.vio_tilt_deg, 1.5 * clean.vio_tilt_deg);
  EXPECT_LT(clean.vio_pct, kPressureVioBoundPct);
  EXPECT_LT(clean.vio_tilt_deg, kPressureTiltBoundDeg);
}

// Over 200 s of the field the altitude climbs past the sonar's 4 m range (about 110-180 s): the
// sonar publishes +inf, the filter says so, the estimator says it bridges the gap (the seabed
// it last measured, the pressure depth), and the odometry stays within the bound of the whole
// run with the sonar.
TEST(Terrain, ASeabedBeyondTheSonarsRangeIsBridgedAndSaid) {
  const RunFigures run = runOn("terrain_dropoff", "pressure", kLocalPlanePressure);
  EXPECT_TRUE(contains(run.offline.output, "outside [")) << run.offline.output;  // the filter's dropout line
  EXPECT_TRUE(contains(run.offline.output, "sonar gap")) << run.offline.output;  // the estimator's fallback
  EXPECT_LT(run.vio_pct, kDropoffVioBoundPct);
  EXPECT_LT(run.vio_tilt_deg, kDropoffTiltBoundDeg);
}

// Rocks of 0.15-0.3 m under the beam and in view: the features they put off the seabed plane
// lose their sonar factor, the estimator says so, and the odometry stays accurate.
TEST(Terrain, RocksUnderTheBeamAreDroppedFromTheSeabedAndSaid) {
  const RunFigures run = runOn("terrain_rocks", "pressure", kLocalPlanePressure);
  EXPECT_TRUE(contains(run.offline.output, "off the seabed plane")) << run.offline.output;
  EXPECT_LT(run.vio_pct, kRocksVioBoundPct);
  EXPECT_LT(run.vio_tilt_deg, kRocksTiltBoundDeg);
}

// The contract's lower rates (5 Hz camera, 100 Hz IMU, 2 Hz sonar, 200 Hz magnetometer), read
// from the sequence YAML: the sonar filter acquires (its max_gap_s spans acquire_samples + 1
// periods of a slow sonar) and every frame gets a range, so the scale holds. Measured 0.048 % of
// distance on this sequence (1.8 m, 7.9 %, when the 10 Hz constants held).
TEST(Rigs, ASlowRigKeepsItsScale) {
  const RunFigures f = runOn("rig_slow", "default", "  use_sonar: true\n");
  EXPECT_LT(f.vio_pct, 0.1);
}

// A fisheye rig (the contract's equidistant model, about 110 deg across behind a dome port): the
// tracker, the estimator and the loop verification use the one CameraModel read from the YAML,
// and the reprojection residuals are weighted through its lens (lens_weighting: auto). Measured
// 0.059 % of distance on this sequence (0.062 % with the focal scaling; the pinhole rig of the
// same seed: 0.037 %; docs/benchmarks.md, "Fisheye weighting").
TEST(Rigs, AFisheyeRigKeepsItsScale) {
  const RunFigures f = runOn("rig_fisheye", "default", "  use_sonar: true\n");
  EXPECT_LT(f.vio_pct, 0.12);
}

// A camera turned 90 deg about its optical axis and tilted 15 deg forward (config/rigs/rotated.yaml,
// through vims_sim --rig): the mounting reaches VIMS only through the YAML's T_b_c, and the sonar
// depth factors relate the seabed to the real viewing geometry. Measured 0.036 % of distance on
// this sequence (the downward camera of the same seed: 0.037 %).
TEST(Rigs, ATurnedAndTiltedCameraKeepsItsScale) {
  const RunFigures f = runOn("rig_rotated", "default", "  use_sonar: true\n");
  EXPECT_LT(f.vio_pct, 0.07);
}
