// System test of the VIO wiring of vims_offline: runs the built binary on the simulated tank30
// (fixture sim_tank30) in both modes and checks vio.tum, the summary keys and the --mode flag.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>

#include "vims_common/sequence_paths.h"
#include "vims_common/trajectory_io.h"
#include "vims_eval/metrics.h"
#include "vims_test/tool_runner.h"

namespace fs = std::filesystem;

namespace {

using vims::test::CommandResult;
using vims::test::freshDir;
using vims::test::runCommand;

std::string offlineBinary() { return std::string(VIMS_DEVEL_BIN_DIR) + "/vims_offline"; }

std::string tank30() { return vims::test::testSequence("tank30"); }

/// Runs the odometry alone on `seq` into a fresh OUT; returns OUT.
fs::path runVioOnly(const std::string& seq, const std::string& name) {
  const fs::path out = freshDir(name);
  const CommandResult r =
      runCommand(offlineBinary() + " --quiet --vio-only --sequence " + seq + " --out " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return out;
}

std::string fileText(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// The VIO's translation ATE [m] after an SE(3) alignment with the sequence's ground truth.
double vioAte(const std::string& seq, const fs::path& out) {
  vims::eval::TrajectoryEvalOptions options;
  options.alignments = {vims::eval::AlignmentMode::kSe3};
  const auto evaluation = vims::eval::evaluateTrajectory(vims::readTumFile(vims::SequencePaths::resolve(seq).gt),
                                                         vims::readTumFile((out / "vio.tum").string()), options, "vio");
  return evaluation.find(vims::eval::AlignmentMode::kSe3)->ate.rmse;
}

}  // namespace

TEST(OfflineVio, BothModesWriteVioTumAndLatency) {
  const std::string seq = tank30();
  if (seq.empty()) GTEST_SKIP() << "VIMS_TEST_DATA not set (run through ctest)";
  for (const std::string mode : {"full", "no_sonar"}) {
    const fs::path out = freshDir("offline_vio_" + mode);
    const CommandResult r =
        runCommand(offlineBinary() + " --quiet --mode " + mode + " --sequence " + seq + " --out " + out.string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto poses = vims::readTumFile((out / "vio.tum").string());
    EXPECT_GT(poses.size(), 250u) << mode << ": a pose for (almost) every one of the 300 frames";
    const YAML::Node summary = YAML::LoadFile((out / "summary.yaml").string());
    EXPECT_EQ(summary["mode"].as<std::string>(), mode);
    EXPECT_EQ(summary["vio"]["frames"].as<long>(), static_cast<long>(poses.size()));
    EXPECT_EQ(summary["vio"]["resets"].as<int>(), 0);
    for (const char* key : {"frontend_p50", "frontend_p99", "backend_p50", "backend_p99"}) {
      EXPECT_GT(summary["latency_ms"][key].as<double>(), 0.0) << key;
    }
    EXPECT_LE(summary["latency_ms"]["backend_p50"].as<double>(), summary["latency_ms"]["backend_p99"].as<double>());
  }
}

// The pose graph's outputs: one global pose per keyframe, one loops.csv row per verification
// attempt, for the modes that switch descriptors and stages (ORB and BRIEF vocabularies).
TEST(OfflineVio, PoseGraphModesWriteGlobalTrajectoryAndLoopLog) {
  const std::string seq = tank30();
  if (seq.empty()) GTEST_SKIP() << "VIMS_TEST_DATA not set (run through ctest)";
  for (const std::string mode : {"full", "vi_slam", "no_orb"}) {
    const fs::path out = freshDir("offline_pg_" + mode);
    const CommandResult r =
        runCommand(offlineBinary() + " --quiet --mode " + mode + " --sequence " + seq + " --out " + out.string());
    ASSERT_EQ(r.exit_code, 0) << mode << "\n" << r.output;
    const YAML::Node summary = YAML::LoadFile((out / "summary.yaml").string());
    const long keyframes = summary["vio"]["keyframes"].as<long>();
    EXPECT_GT(keyframes, 10) << mode;
    EXPECT_EQ(summary["pose_graph"]["keyframes"].as<long>(), keyframes) << mode;
    const auto global = vims::readTumFile((out / "global.tum").string());
    EXPECT_EQ(static_cast<long>(global.size()), keyframes) << mode;
    std::ifstream loops(out / "loops.csv");
    std::string header;
    std::getline(loops, header);
    EXPECT_EQ(header,
              "t_query,t_match,accepted,x,y,z,qx,qy,qz,qw,inliers,mag_distance,bow_score,stage,sigma_x,sigma_y,sigma_z,"
              "sigma_yaw_deg,match_in_map");
    long rows = 0;
    for (std::string line; std::getline(loops, line);) rows += line.empty() ? 0 : 1;
    EXPECT_EQ(rows, summary["pose_graph"]["loop_attempts"].as<long>()) << mode;
  }
}

static std::string fileContents(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The tracker and pose-graph threads (--threads 2, default) must not change any output: the
// estimator gets each frame at the same point of the message stream as with --threads 1, and the
// pose graph gets its inputs in the same order. Also checks the per-stage
// latency and resource keys of summary.yaml.
TEST(OfflineVio, WorkerThreadsGiveIdenticalOutputs) {
  const std::string seq = tank30();
  if (seq.empty()) GTEST_SKIP() << "VIMS_TEST_DATA not set (run through ctest)";
  std::array<fs::path, 2> outs;
  for (int threads : {1, 2}) {
    outs[threads - 1] = freshDir("offline_vio_threads" + std::to_string(threads));
    const CommandResult r = runCommand(offlineBinary() + " --quiet --threads " + std::to_string(threads) +
                                       " --sequence " + seq + " --out " + outs[threads - 1].string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const YAML::Node summary = YAML::LoadFile((outs[threads - 1] / "summary.yaml").string());
    EXPECT_EQ(summary["threads"].as<int>(), threads);
    for (const char* key : {"magnetometer_p99", "place_recognition_p99", "pose_graph_optimisation_p99"}) {
      EXPECT_GT(summary["latency_ms"][key].as<double>(), 0.0) << key;
    }
    EXPECT_GT(summary["vio_real_time_factor"].as<double>(), 0.0);
    EXPECT_GT(summary["vio_cpu_s"]["frontend"].as<double>(), 0.0);
    EXPECT_GT(summary["vio_cpu_s"]["backend"].as<double>(), 0.0);
    EXPECT_GT(summary["peak_rss_mb"].as<double>(), 10.0);
    // The process's CPU time holds the VIO's threads and more (bag reading, magnetometer, pose graph).
    EXPECT_GT(summary["cpu_s"]["total"].as<double>(),
              summary["vio_cpu_s"]["frontend"].as<double>() + summary["vio_cpu_s"]["backend"].as<double>());
    EXPECT_GT(summary["cpu_s"]["per_sequence_s"].as<double>(), 0.0);
  }
  for (const char* file : {"vio.tum", "global.tum", "loops.csv"}) {
    const std::string one = fileContents(outs[0] / file);
    EXPECT_FALSE(one.empty()) << file;
    EXPECT_TRUE(one == fileContents(outs[1] / file)) << file << " differs between --threads 1 and 2";
  }
  const CommandResult bad =
      runCommand(offlineBinary() + " --threads 3 --sequence x --out " + freshDir("offline_vio_badthreads").string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
}

// --vio-only runs the same odometry without the pose graph: nothing the pose graph does flows
// back into the estimator, so vio.tum must be byte-identical to a full run's.
TEST(OfflineVio, VioOnlyGivesTheFullRunsOdometry) {
  const std::string seq = tank30();
  if (seq.empty()) GTEST_SKIP() << "VIMS_TEST_DATA not set (run through ctest)";
  const fs::path full = freshDir("offline_vio_full");
  const fs::path vio = freshDir("offline_vio_only");
  CommandResult r = runCommand(offlineBinary() + " --quiet --sequence " + seq + " --out " + full.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = runCommand(offlineBinary() + " --quiet --vio-only --sequence " + seq + " --out " + vio.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string full_vio = fileContents(full / "vio.tum");
  EXPECT_FALSE(full_vio.empty());
  EXPECT_TRUE(full_vio == fileContents(vio / "vio.tum")) << "vio.tum differs with --vio-only";
  EXPECT_FALSE(fs::exists(vio / "global.tum"));
  EXPECT_FALSE(fs::exists(vio / "loops.csv"));
  const YAML::Node summary = YAML::LoadFile((vio / "summary.yaml").string());
  EXPECT_TRUE(summary["vio_only"].as<bool>());
  EXPECT_EQ(summary["pose_graph"]["keyframes"].as<int>(), 0);
  EXPECT_GT(summary["vio"]["keyframes"].as<int>(), 0);
  const CommandResult with_map =
      runCommand(offlineBinary() + " --quiet --vio-only --map-save " + (vio / "m.vimsmap").string() + " --sequence " +
                 seq + " --out " + freshDir("offline_vio_only_map").string());
  EXPECT_EQ(with_map.exit_code, 1) << with_map.output;
  EXPECT_NE(with_map.output.find("--vio-only"), std::string::npos) << with_map.output;
}

TEST(OfflineVio, UnknownModeIsAUsageError) {
  const CommandResult r =
      runCommand(offlineBinary() + " --mode fast --sequence x --out " + freshDir("offline_vio_badmode").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("unknown mode 'fast'"), std::string::npos) << r.output;
}

// Contract version 2: the camera topic may carry sensor_msgs/CompressedImage. The same tank30
// recorded as png (lossless) gives the raw bag's odometry to the bit; as jpeg (quality 95) the
// codec's loss moves the tracks a little: measured ATE 3.4 mm raw, 7.2 mm jpeg.
TEST(OfflineVio, CompressedImagesGiveTheRawOdometry) {
  const std::string raw = tank30();
  const std::string png = vims::test::testSequence("tank30_png");
  const std::string jpeg = vims::test::testSequence("tank30_jpeg");
  if (raw.empty()) GTEST_SKIP() << "VIMS_TEST_DATA not set (run through ctest)";
  const fs::path out_raw = runVioOnly(raw, "offline_images_raw");
  const fs::path out_png = runVioOnly(png, "offline_images_png");
  const fs::path out_jpeg = runVioOnly(jpeg, "offline_images_jpeg");
  const YAML::Node summary = YAML::LoadFile((out_png / "summary.yaml").string());
  EXPECT_EQ(summary["messages"]["/cam0/image_raw/compressed"]["type"].as<std::string>(), "sensor_msgs/CompressedImage");
  EXPECT_EQ(summary["messages"]["/cam0/image_raw/compressed"]["rejected"].as<int>(), 0);
  const std::string raw_tum = fileText(out_raw / "vio.tum");
  ASSERT_FALSE(raw_tum.empty());
  EXPECT_EQ(fileText(out_png / "vio.tum"), raw_tum) << "png is lossless: the same images, the same odometry";
  EXPECT_LT(vioAte(raw, out_raw), 0.007);
  EXPECT_LT(vioAte(jpeg, out_jpeg), 0.015);
}
