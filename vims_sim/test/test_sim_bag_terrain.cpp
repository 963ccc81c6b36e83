// End to end over terrain with the pressure sensor: the pressure messages against the depth of
// the port, the sonar against the terrain, and determinism whatever the thread count.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/Range.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <vector>

#include "sim_bag_test_support.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/trajectory_io.h"
#include "vims_sim/sensor_models.h"
#include "vims_sim/sim_truth.h"

using namespace vims::sim;
using namespace vims::sim::bag_test;
namespace fs = std::filesystem;

namespace {

Eigen::Isometry3d gtPose(const vims::StampedPose& pose) {
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.linear() = pose.q.toRotationMatrix();
  T_w_b.translation() = pose.p;
  return T_w_b;
}

}  // namespace

TEST(SimulatorDeterminism, TerrainAndPressureWhateverTheThreadCount) {
  SimOptions a = baseOptions("det_terrain_a", 2.0, 5);
  a.static_start = 1.0;
  a.terrain.preset = "rough";
  a.pressure.enabled = true;
  a.render_threads = 1;
  SimOptions b = a;
  b.out_dir = (tempRoot() / "det_terrain_b").string();
  b.name = "det_terrain_a";
  b.render_threads = 3;
  generate(a);
  generate(b);
  const auto pa = vims::SequencePaths::resolve(a.out_dir), pb = vims::SequencePaths::resolve(b.out_dir);
  EXPECT_EQ(serialisedMessages(pa.bag), serialisedMessages(pb.bag));
  EXPECT_EQ(readFile(pa.truth), readFile(pb.truth));
  fs::remove_all(a.out_dir);
  fs::remove_all(b.out_dir);
}

/// 20 s over the slope4 seabed with the pressure sensor (one pressure-off span).
class TerrainSequence : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    options_ = baseOptions("terrain20", 20.0, 12);
    options_.terrain.preset = "slope4";
    options_.pressure.enabled = true;
    options_.spans.pressure_off = {{12.0, 13.0}};
    generate(options_);
    paths_ = vims::SequencePaths::resolve(options_.out_dir);
  }
  static void TearDownTestSuite() { fs::remove_all(tempRoot()); }

  static SimOptions options_;
  static vims::SequencePaths paths_;
};
SimOptions TerrainSequence::options_;
vims::SequencePaths TerrainSequence::paths_;

TEST_F(TerrainSequence, PressureMessagesMatchTheDepthOfThePort) {
  const auto gt = vims::readTumFile(paths_.gt);
  const SimTruth truth = SimTruth::load(paths_.truth);
  std::vector<std::string> unknown;
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths_.yaml, &unknown);
  EXPECT_TRUE(unknown.empty());
  ASSERT_TRUE(config.pressure.has_value());
  ASSERT_TRUE(truth.pressure.has_value());
  EXPECT_FALSE(truth.terrain.isFlat());
  rosbag::Bag bag(paths_.bag, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery(config.topics.pressure));
  std::vector<double> stamps;
  double sum = 0.0, sum_sq = 0.0, depth_min = 1e9, depth_max = -1e9;
  for (const rosbag::MessageInstance& m : view) {
    EXPECT_EQ(m.getDataType(), "sensor_msgs/FluidPressure");
    auto msg = m.instantiate<sensor_msgs::FluidPressure>();
    ASSERT_TRUE(msg);
    EXPECT_EQ(msg->header.frame_id, "pressure");
    EXPECT_EQ(m.getTime(), msg->header.stamp);
    EXPECT_EQ(msg->variance, config.pressure->noise_std_pa * config.pressure->noise_std_pa);
    const double t = msg->header.stamp.toSec() - truth.start_time;
    stamps.push_back(t);
    // Pressure samples lie on the IMU grid (25 ms + k 100 ms), so the TUM pose is the true one.
    const size_t i = static_cast<size_t>(std::llround(t * 200.0));
    ASSERT_LT(i, gt.size());
    const double z_port = (gtPose(gt[i]) * config.pressure->T_b_p.translation()).z();
    const double expected = truth.pressure->water.pressureAt(z_port);
    sum += msg->fluid_pressure - expected;
    sum_sq += (msg->fluid_pressure - expected) * (msg->fluid_pressure - expected);
    const double depth = config.pressure->depthOf(msg->fluid_pressure, config.imu.gravity);
    depth_min = std::min(depth_min, depth);
    depth_max = std::max(depth_max, depth);
  }
  const double n = static_cast<double>(stamps.size());
  std::cout << "pressure: " << stamps.size() << " samples, residual mean " << sum / n << " Pa, std "
            << std::sqrt(sum_sq / n) << " Pa, port depth " << depth_min << " .. " << depth_max << " m\n";
  EXPECT_EQ(stamps.size(), 190u);  // 10 Hz for 20 s minus the 1 s span
  EXPECT_NEAR(stamps.front(), 0.025, 1e-6);
  EXPECT_NEAR(stamps[1] - stamps[0], 0.1, 1e-6);
  EXPECT_EQ(std::count_if(stamps.begin(), stamps.end(), [](double t) { return t >= 12.0 && t < 13.0; }), 0);
  EXPECT_NEAR(std::sqrt(sum_sq / n), config.pressure->noise_std_pa, 0.15 * config.pressure->noise_std_pa);
  EXPECT_NEAR(sum / n, 0.0, 5.0 * config.pressure->noise_std_pa / std::sqrt(n));
  EXPECT_GT(depth_min, 3.0);  // the tank's water is 9-11 m deep
}

TEST_F(TerrainSequence, SonarRangesMatchTheTerrain) {
  const auto gt = vims::readTumFile(paths_.gt);
  const SimTruth truth = SimTruth::load(paths_.truth);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths_.yaml);
  const SeabedTerrain terrain = terrainFromTruth(truth);
  rosbag::Bag bag(paths_.bag, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/sonar/range"));
  int finite = 0, within = 0, within_flat = 0;
  for (const rosbag::MessageInstance& m : view) {
    auto range = m.instantiate<sensor_msgs::Range>();
    if (std::isinf(range->range)) continue;
    const size_t i = static_cast<size_t>(std::llround((range->header.stamp.toSec() - truth.start_time) * 200.0));
    const Eigen::Isometry3d T_w_b = gtPose(gt[i]);
    const double expected = SonarSimulator::trueRange(T_w_b, config.sonar.T_b_s, terrain, config.sonar.max_range);
    const double flat = SonarSimulator::trueRange(T_w_b, config.sonar.T_b_s);
    ++finite;
    if (std::abs(range->range - expected) < 4.0 * config.sonar.range_noise_std) ++within;
    if (std::abs(range->range - flat) < 4.0 * config.sonar.range_noise_std) ++within_flat;
  }
  std::cout << "sonar over terrain: " << within << " of " << finite << " finite ranges within 4 sigma of the terrain ("
            << within_flat << " of the plane z = 0)\n";
  EXPECT_GE(within, 0.9 * finite);
  EXPECT_LT(within_flat, 0.5 * finite);
}
