// System tests of vims_offline: runs the built binary on a simulated sequence and on broken
// sequence directories, and checks its outputs and error messages.
#include <gtest/gtest.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Imu.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "vims_test/tool_runner.h"

namespace fs = std::filesystem;

namespace {

using vims::test::CommandResult;
using vims::test::freshDir;
using vims::test::runCommand;

std::string offlineBinary() { return std::string(VIMS_DEVEL_BIN_DIR) + "/vims_offline"; }
std::string testData(const std::string& name) { return vims::test::testSequence(name); }

}  // namespace

TEST(OfflineRunner, WritesSummaryWithMessageCountsAndRealTimeFactor) {
  const std::string seq = testData("tank30");
  ASSERT_FALSE(seq.empty()) << "VIMS_TEST_DATA not set (run through ctest)";
  const fs::path out = freshDir("offline_tank30");
  const CommandResult r = runCommand(offlineBinary() + " --quiet --sequence " + seq + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("VIMS_OFFLINE sequence=tank30"), std::string::npos) << r.output;

  const YAML::Node summary = YAML::LoadFile((out / "summary.yaml").string());
  const double duration = summary["sequence_duration_s"].as<double>();
  EXPECT_NEAR(duration, 30.0, 0.5);
  EXPECT_GT(summary["real_time_factor"].as<double>(), 1.0);
  EXPECT_GT(summary["wall_time_s"].as<double>(), 0.0);
  const YAML::Node messages = summary["messages"];
  // Counts follow the contract's rates (tolerance for the first/last sample at the span ends).
  EXPECT_NEAR(messages["/imu0"]["count"].as<double>(), 200.0 * duration, 3.0);
  EXPECT_NEAR(messages["/mag/raw"]["count"].as<double>(), 1000.0 * duration, 5.0);
  EXPECT_NEAR(messages["/cam0/image_raw"]["count"].as<double>(), 10.0 * duration, 2.0);
  EXPECT_NEAR(messages["/sonar/range"]["count"].as<double>(), 10.0 * duration, 2.0);
  EXPECT_EQ(messages["/imu0"]["type"].as<std::string>(), "sensor_msgs/Imu");
  EXPECT_EQ(messages["/imu0"]["rejected"].as<int>(), 0);

  // Front-end outputs: one sonar row per message; one signature per 0.4 s hop after the first 2 s window.
  const auto countLines = [](const fs::path& path, std::string* header) {
    std::ifstream in(path);
    std::string line;
    std::getline(in, *header);
    int rows = 0;
    while (std::getline(in, line)) rows += line.empty() ? 0 : 1;
    return rows;
  };
  std::string header;
  EXPECT_EQ(countLines(out / "sonar_filtered.csv", &header), messages["/sonar/range"]["count"].as<int>());
  EXPECT_EQ(header, "t,raw_range,filtered_range,accepted,status");
  const int windows = countLines(out / "mag_signatures.csv", &header);
  EXPECT_EQ(header, "t,E,N,U,snr,valid,coil,invalid_reason");
  EXPECT_NEAR(windows, (duration - 2.0) / 0.4, 3.0);
  EXPECT_EQ(summary["magnetometer"]["windows"].as<int>(), windows);
  EXPECT_GT(summary["sonar_filter"]["accepted"].as<int>(), 0.9 * messages["/sonar/range"]["count"].as<int>());
}

TEST(OfflineRunner, RunsWithoutOptionalSensorsAndSaysSo) {
  const std::string seq = testData("tank30");
  ASSERT_FALSE(seq.empty());
  // Copy the camera and IMU messages only: no sonar, no magnetometer.
  const fs::path dir = freshDir("cam_imu_only");
  fs::copy_file(fs::path(seq) / "tank30.yaml", dir / "cam_imu_only.yaml");
  {
    rosbag::Bag in((fs::path(seq) / "tank30.bag").string(), rosbag::bagmode::Read);
    rosbag::Bag out((dir / "cam_imu_only.bag").string(), rosbag::bagmode::Write);
    rosbag::View view(in, rosbag::TopicQuery(std::vector<std::string>{"/cam0/image_raw", "/imu0"}));
    for (const rosbag::MessageInstance& m : view) out.write(m.getTopic(), m.getTime(), m);
  }
  const CommandResult r =
      runCommand(offlineBinary() + " --quiet --sequence " + dir.string() + " --out " + (dir / "out").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("no '/sonar/range' messages"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("no '/mag/raw' messages"), std::string::npos) << r.output;
}

/// Contract v2: a sequence may leave the coil frequency open (null); the magnetometer front end
/// finds it in the first 10 s and then gives the signatures of the stated frequency.
TEST(OfflineRunner, AnOpenCoilFrequencyIsFoundFromTheData) {
  const std::string seq = testData("tank30");
  ASSERT_FALSE(seq.empty());
  const fs::path dir = freshDir("coil_open");
  fs::create_symlink(fs::path(seq) / "tank30.bag", dir / "coil_open.bag");
  YAML::Node yaml = YAML::LoadFile((fs::path(seq) / "tank30.yaml").string());
  const double stated = yaml["magnetometer"]["coil_frequency_hz"].as<double>();
  yaml["magnetometer"]["coil_frequency_hz"] = YAML::Node(YAML::NodeType::Null);
  std::ofstream(dir / "coil_open.yaml") << yaml;

  const fs::path out_open = freshDir("coil_open_out");
  const fs::path out_stated = freshDir("coil_stated_out");
  const CommandResult open =
      runCommand(offlineBinary() + " --sequence " + dir.string() + " --out " + out_open.string());
  ASSERT_EQ(open.exit_code, 0) << open.output;
  EXPECT_NE(open.output.find("coil frequency found"), std::string::npos) << open.output;
  const CommandResult stated_run =
      runCommand(offlineBinary() + " --quiet --sequence " + seq + " --out " + out_stated.string());
  ASSERT_EQ(stated_run.exit_code, 0) << stated_run.output;

  const YAML::Node a = YAML::LoadFile((out_open / "summary.yaml").string())["magnetometer"];
  const YAML::Node b = YAML::LoadFile((out_stated / "summary.yaml").string())["magnetometer"];
  EXPECT_NEAR(a["coil_frequency_hz"].as<double>(), stated, 0.02);  // measured 1.2 mHz off on tank60
  // The first 10 s are buffered and processed once found: the same windows, as many valid.
  EXPECT_EQ(a["windows"].as<int>(), b["windows"].as<int>());
  EXPECT_NEAR(a["valid_windows"].as<double>(), b["valid_windows"].as<double>(), 2.0);
}

TEST(OfflineRunner, MissingSequenceFilesAreNamed) {
  const fs::path empty = freshDir("seq_empty");
  CommandResult r =
      runCommand(offlineBinary() + " --quiet --sequence " + empty.string() + " --out " + (empty / "out").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("has no bag"), std::string::npos) << r.output;

  r = runCommand(offlineBinary() + " --quiet --sequence /nonexistent/seq --out /tmp/x");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("does not exist"), std::string::npos) << r.output;

  r = runCommand(offlineBinary() + " --sequence");
  EXPECT_EQ(r.exit_code, 2);
  r = runCommand(offlineBinary() + " --bogus");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--bogus"), std::string::npos);
}

TEST(OfflineRunner, BagWithoutATopicIsRejectedNamingTheTopic) {
  const std::string seq = testData("tank30");
  ASSERT_FALSE(seq.empty());
  const fs::path dir = freshDir("imu_only");
  fs::copy_file(fs::path(seq) / "tank30.yaml", dir / "imu_only.yaml");
  {
    rosbag::Bag bag((dir / "imu_only.bag").string(), rosbag::bagmode::Write);
    for (int i = 0; i < 10; ++i) {
      sensor_msgs::Imu msg;
      msg.header.stamp = ros::Time(100.0 + 0.005 * i);
      msg.linear_acceleration.z = 9.81;
      bag.write("/imu0", msg.header.stamp, msg);
    }
  }
  const CommandResult r =
      runCommand(offlineBinary() + " --quiet --sequence " + dir.string() + " --out " + (dir / "out").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("has no topic '/cam0/image_raw'"), std::string::npos) << r.output;
}

TEST(OfflineRunner, BadSequenceYamlAndConfigKeysAreNamed) {
  const std::string seq = testData("tank30");
  ASSERT_FALSE(seq.empty());
  const fs::path dir = freshDir("bad_yaml");
  fs::copy_file(fs::path(seq) / "tank30.bag", dir / "bad_yaml.bag");
  {
    std::ifstream in(fs::path(seq) / "tank30.yaml");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto pos = text.find("  rate_hz: 200");
    ASSERT_NE(pos, std::string::npos);
    text.replace(pos, 14, "  rate_hz: -200");
    std::ofstream(dir / "bad_yaml.yaml") << text;
  }
  CommandResult r =
      runCommand(offlineBinary() + " --quiet --sequence " + dir.string() + " --out " + (dir / "out").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("imu.rate_hz"), std::string::npos) << r.output;

  const fs::path config = dir / "config.yaml";
  std::ofstream(config) << "no_such_section: {a: 1}\n";
  r = runCommand(offlineBinary() + " --quiet --sequence " + seq + " --config " + config.string() + " --out " +
                 (dir / "out2").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("no_such_section"), std::string::npos) << r.output;
}

int main(int argc, char** argv) {
  ros::Time::init();
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
