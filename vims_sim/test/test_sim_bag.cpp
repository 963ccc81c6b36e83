// End to end: generate short sequences through the rosbag sink, read them back with
// rosbag::View and check them against the sensor contract and the ground truth; and the default
// flat sequence against the bytes it always had (terrain and pressure: test_sim_bag_terrain.cpp).
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <ros/serialization.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Range.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "bag_sink.h"
#include "sim_bag_test_support.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/trajectory_io.h"
#include "vims_sim/sequence_generator.h"
#include "vims_sim/sim_setup.h"
#include "vims_sim/sim_truth.h"

using namespace vims::sim;
using namespace vims::sim::bag_test;
namespace fs = std::filesystem;

namespace {

/// The sequence every check below reads: 20 s with a camera delay and one span of each kind.
class GeneratedSequence : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    options_ = baseOptions("seq20", 20.0, 31);
    options_.camera_delay = 0.03;
    options_.spans.camera_blackout = {{5.0, 6.0}};
    options_.spans.camera_off = {{8.0, 9.0}};
    options_.spans.sonar_off = {{10.0, 11.0}};
    options_.spans.mag_off = {{12.0, 12.5}};
    options_.spans.imu_gap = {{14.0, 14.5}};
    stats_ = generate(options_);
    paths_ = vims::SequencePaths::resolve(options_.out_dir);
  }
  static void TearDownTestSuite() { fs::remove_all(tempRoot()); }

  static SimOptions options_;
  static GenerationStats stats_;
  static vims::SequencePaths paths_;
};
SimOptions GeneratedSequence::options_;
GenerationStats GeneratedSequence::stats_;
vims::SequencePaths GeneratedSequence::paths_;

}  // namespace

TEST_F(GeneratedSequence, FilesFollowTheContract) {
  EXPECT_EQ(paths_.name, "seq20");
  EXPECT_FALSE(paths_.gt.empty());
  EXPECT_FALSE(paths_.truth.empty());
  std::vector<std::string> unknown;
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths_.yaml, &unknown);
  EXPECT_TRUE(unknown.empty());
  EXPECT_EQ(config.topics.image, "/cam0/image_raw");
  const SimTruth truth = SimTruth::load(paths_.truth);
  EXPECT_EQ(truth.camera_time_delay, 0.03);
  EXPECT_EQ(truth.dropouts.imu_gap.size(), 1u);
  const auto gt = vims::readTumFile(paths_.gt);
  ASSERT_EQ(gt.size(), 4000u);  // 200 Hz for 20 s, IMU gaps included
  EXPECT_NEAR(gt.front().t, 1700000000.0, 1e-6);
  EXPECT_NEAR(gt[1].t - gt[0].t, 0.005, 1e-6);
}

TEST_F(GeneratedSequence, TopicsTypesRatesFrameIdsAndOrder) {
  rosbag::Bag bag(paths_.bag, rosbag::bagmode::Read);
  rosbag::View view(bag);
  struct TopicInfo {
    std::string type;
    std::vector<double> stamps;
    std::set<std::string> frame_ids;
  };
  std::map<std::string, TopicInfo> topics;
  double last_bag_time = 0.0;
  bool bag_time_ordered = true, bag_time_is_stamp = true;
  for (const rosbag::MessageInstance& m : view) {
    TopicInfo& info = topics[m.getTopic()];
    info.type = m.getDataType();
    std::string frame_id;
    ros::Time stamp;
    if (auto imu = m.instantiate<sensor_msgs::Imu>()) {
      stamp = imu->header.stamp;
      frame_id = imu->header.frame_id;
      EXPECT_EQ(imu->orientation_covariance[0], -1.0);
    } else if (auto image = m.instantiate<sensor_msgs::Image>()) {
      stamp = image->header.stamp;
      frame_id = image->header.frame_id;
    } else if (auto range = m.instantiate<sensor_msgs::Range>()) {
      stamp = range->header.stamp;
      frame_id = range->header.frame_id;
      EXPECT_EQ(range->radiation_type, sensor_msgs::Range::ULTRASOUND);
      EXPECT_NEAR(range->field_of_view, 0.1, 1e-6);
      EXPECT_GT(range->max_range, range->min_range);
    } else if (auto mag = m.instantiate<sensor_msgs::MagneticField>()) {
      stamp = mag->header.stamp;
      frame_id = mag->header.frame_id;
    } else if (auto pose = m.instantiate<geometry_msgs::PoseStamped>()) {
      stamp = pose->header.stamp;
      frame_id = pose->header.frame_id;
    }
    info.stamps.push_back(toSeconds(stamp));
    info.frame_ids.insert(frame_id);
    bag_time_ordered &= m.getTime().toSec() >= last_bag_time;
    bag_time_is_stamp &= m.getTime() == stamp;
    last_bag_time = m.getTime().toSec();
  }
  EXPECT_TRUE(bag_time_ordered);
  EXPECT_TRUE(bag_time_is_stamp);

  struct Expected {
    std::string topic, type, frame_id;
    double rate, gap;  // rate [Hz] and total span without messages [s]
  };
  const std::vector<Expected> expected = {
      {"/cam0/image_raw", "sensor_msgs/Image", "camera", 10.0, 1.0},
      {"/imu0", "sensor_msgs/Imu", "body", 200.0, 0.5},
      {"/sonar/range", "sensor_msgs/Range", "sonar", 10.0, 1.0},
      {"/mag/raw", "sensor_msgs/MagneticField", "mag", 1000.0, 0.5},
      {"/ground_truth/pose", "geometry_msgs/PoseStamped", "world", 50.0, 0.0},
  };
  ASSERT_EQ(topics.size(), expected.size());
  for (const Expected& e : expected) {
    ASSERT_TRUE(topics.count(e.topic)) << e.topic;
    const TopicInfo& info = topics[e.topic];
    EXPECT_EQ(info.type, e.type) << e.topic;
    EXPECT_EQ(info.frame_ids, std::set<std::string>{e.frame_id}) << e.topic;
    for (size_t i = 1; i < info.stamps.size(); ++i)
      ASSERT_GT(info.stamps[i], info.stamps[i - 1]) << e.topic << " " << i;
    const double count = static_cast<double>(info.stamps.size());
    EXPECT_NEAR(count / (20.0 - e.gap), e.rate, 0.02 * e.rate) << e.topic;
    // The rate between consecutive stamps outside the gaps is exact.
    EXPECT_NEAR(info.stamps[1] - info.stamps[0], 1.0 / e.rate, 1e-6) << e.topic;
  }
  // Spans: no messages inside, messages on both sides.
  auto countIn = [&](const std::string& topic, double a, double b) {
    const auto& s = topics[topic].stamps;
    return std::count_if(s.begin(), s.end(), [&](double t) { return t >= 1700000000.0 + a && t < 1700000000.0 + b; });
  };
  EXPECT_EQ(countIn("/cam0/image_raw", 8.03, 9.03), 0);
  EXPECT_EQ(countIn("/sonar/range", 10.0, 11.0), 0);
  EXPECT_EQ(countIn("/mag/raw", 12.0, 12.5), 0);
  EXPECT_EQ(countIn("/imu0", 14.0, 14.5), 0);
  EXPECT_EQ(countIn("/imu0", 13.0, 14.0), 200);
  EXPECT_EQ(countIn("/ground_truth/pose", 0.0, 20.0), 1000);
  // Camera stamps = exposure (multiples of 100 ms) + 30 ms delay.
  const auto& image_stamps = topics["/cam0/image_raw"].stamps;
  EXPECT_NEAR(image_stamps.front(), 1700000000.03, 1e-6);
  EXPECT_EQ(stats_.image_messages, static_cast<int64_t>(image_stamps.size()));
}

TEST_F(GeneratedSequence, ImagesAreMono8AndBlackDuringTheBlackout) {
  rosbag::Bag bag(paths_.bag, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/cam0/image_raw"));
  int black = 0, lit = 0;
  for (const rosbag::MessageInstance& m : view) {
    auto image = m.instantiate<sensor_msgs::Image>();
    ASSERT_TRUE(image);
    ASSERT_EQ(image->encoding, "mono8");
    ASSERT_EQ(image->width, 640u);
    ASSERT_EQ(image->height, 480u);
    ASSERT_EQ(image->step, 640u);
    ASSERT_EQ(image->data.size(), 640u * 480u);
    double mean = 0.0;
    for (uint8_t v : image->data) mean += v;
    mean /= image->data.size();
    const double t = image->header.stamp.toSec() - 1700000000.0 - 0.03;
    if (t >= 5.0 - 1e-6 && t < 6.0 - 1e-6) {
      EXPECT_LT(mean, 3.0) << t;
      ++black;
    } else {
      EXPECT_GT(mean, 25.0) << t;
      ++lit;
    }
  }
  EXPECT_EQ(black, 10);
  EXPECT_EQ(lit, 180);
  EXPECT_GE(stats_.median_corners, 100.0);
}

TEST_F(GeneratedSequence, ImuAgreesWithTheGroundTruthWithinItsNoise) {
  const auto gt = vims::readTumFile(paths_.gt);
  const SimTruth truth = SimTruth::load(paths_.truth);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths_.yaml);
  std::map<int64_t, size_t> index_of;  // stamp in 5 ms ticks -> GT index
  for (size_t i = 0; i < gt.size(); ++i) index_of[std::llround((gt[i].t - 1700000000.0) * 200.0)] = i;

  rosbag::Bag bag(paths_.bag, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/imu0"));
  const int h = 20;  // 0.1 s central differences on the 200 Hz ground truth (1e-6 m rounding in the file)
  const double dt = 0.005;
  Eigen::Vector3d gyro_sum = Eigen::Vector3d::Zero(), accel_sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_sq = Eigen::Vector3d::Zero(), accel_sq = Eigen::Vector3d::Zero();
  int n = 0;
  for (const rosbag::MessageInstance& m : view) {
    auto imu = m.instantiate<sensor_msgs::Imu>();
    const int64_t tick = std::llround((imu->header.stamp.toSec() - 1700000000.0) * 200.0);
    ASSERT_TRUE(index_of.count(tick));
    const size_t i = index_of[tick];
    if (i < static_cast<size_t>(h) || i + h >= gt.size()) continue;
    const Eigen::Vector3d a_w = (gt[i + h].p - 2.0 * gt[i].p + gt[i - h].p) / (h * dt * h * dt);
    const Eigen::Matrix3d R_w_b = gt[i].q.toRotationMatrix();
    const Eigen::Vector3d f_gt = R_w_b.transpose() * (a_w + Eigen::Vector3d(0, 0, config.imu.gravity));
    const Eigen::AngleAxisd delta(gt[i - 1].q.toRotationMatrix().transpose() * gt[i + 1].q.toRotationMatrix());
    const Eigen::Vector3d w_gt = delta.angle() * delta.axis() / (2.0 * dt);
    const Eigen::Vector3d gyro(imu->angular_velocity.x, imu->angular_velocity.y, imu->angular_velocity.z);
    const Eigen::Vector3d accel(imu->linear_acceleration.x, imu->linear_acceleration.y, imu->linear_acceleration.z);
    const Eigen::Vector3d eg = gyro - w_gt - truth.gyro_bias, ea = accel - f_gt - truth.accel_bias;
    gyro_sum += eg;
    accel_sum += ea;
    gyro_sq += eg.cwiseProduct(eg);
    accel_sq += ea.cwiseProduct(ea);
    ++n;
  }
  ASSERT_GT(n, 3500);
  const double gyro_std = config.imu.gyro_noise_density * std::sqrt(config.imu.rate_hz);
  const double accel_std = config.imu.accel_noise_density * std::sqrt(config.imu.rate_hz);
  std::cout << "IMU - ground truth residual std / white-noise std: gyro "
            << (gyro_sq / n).cwiseSqrt().transpose() / gyro_std << ", accel "
            << (accel_sq / n).cwiseSqrt().transpose() / accel_std << "\n";
  for (int k = 0; k < 3; ++k) {
    // Residual = white noise (+ a bias random walk that stays tiny over 20 s).
    EXPECT_NEAR(gyro_sum[k] / n, 0.0, 5.0 * gyro_std / std::sqrt(n) + 5e-5) << k;
    EXPECT_NEAR(accel_sum[k] / n, 0.0, 5.0 * accel_std / std::sqrt(n) + 2e-4) << k;
    EXPECT_NEAR(std::sqrt(gyro_sq[k] / n), gyro_std, 0.08 * gyro_std) << k;
    EXPECT_NEAR(std::sqrt(accel_sq[k] / n), accel_std, 0.08 * accel_std) << k;
  }
}

TEST_F(GeneratedSequence, SonarRangesMatchTheGeometry) {
  const auto gt = vims::readTumFile(paths_.gt);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths_.yaml);
  std::map<int64_t, size_t> index_of;
  for (size_t i = 0; i < gt.size(); ++i) index_of[std::llround((gt[i].t - 1700000000.0) * 200.0)] = i;
  rosbag::Bag bag(paths_.bag, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/sonar/range"));
  int finite = 0, within = 0, outliers = 0, dropouts = 0, total = 0;
  for (const rosbag::MessageInstance& m : view) {
    auto range = m.instantiate<sensor_msgs::Range>();
    ++total;
    if (std::isinf(range->range)) {
      EXPECT_GT(range->range, 0.0f);
      ++dropouts;
      continue;
    }
    const int64_t tick = std::llround((range->header.stamp.toSec() - 1700000000.0) * 200.0);
    ASSERT_TRUE(index_of.count(tick));
    const auto& pose = gt[index_of[tick]];
    Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
    T_w_b.linear() = pose.q.toRotationMatrix();
    T_w_b.translation() = pose.p;
    const Eigen::Isometry3d T_w_s = T_w_b * config.sonar.T_b_s;
    const double expected = -T_w_s.translation().z() / T_w_s.linear().col(2).z();
    ++finite;
    if (std::abs(range->range - expected) < 4.0 * config.sonar.range_noise_std) ++within;
    if (range->range > 1.25 * expected) ++outliers;
  }
  std::cout << "sonar: " << total << " pings, " << dropouts << " dropouts, " << outliers << " outliers, " << within
            << " of " << finite << " finite ranges within 4 sigma of the geometry\n";
  EXPECT_EQ(total, 190);
  EXPECT_GE(within, 0.9 * finite);
  // About 3 % multipath outliers and 1 % dropouts (190 pings: loose bounds).
  EXPECT_GE(outliers, 1);
  EXPECT_LE(outliers, 14);
  EXPECT_LE(dropouts, 7);
}

TEST_F(GeneratedSequence, MagnetometerSeesTheEarthAndTheCoil) {
  const auto gt = vims::readTumFile(paths_.gt);
  const SimTruth truth = SimTruth::load(paths_.truth);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths_.yaml);
  rosbag::Bag bag(paths_.bag, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/mag/raw"));
  // The measurement must equal the noise-free prediction (ground truth + truth file: earth and
  // coil) up to the sensor noise. Then, Hann-windowed demodulation at the coil frequency (and at
  // 17 Hz, where there is nothing) of the measurement minus the predicted earth field, against
  // the predicted coil field alone.
  const double f_coil = config.magnetometer.coil_frequency_hz;
  const double T = truth.duration;
  std::complex<double> measured[3], coil_only[3], off_frequency[3];
  double magnitude_sum = 0.0, window_sum = 0.0, worst_residual = 0.0;
  int n = 0;
  for (const rosbag::MessageInstance& m : view) {
    auto mag = m.instantiate<sensor_msgs::MagneticField>();
    const Eigen::Vector3d b(mag->magnetic_field.x, mag->magnetic_field.y, mag->magnetic_field.z);
    magnitude_sum += b.norm();
    const double t = mag->header.stamp.toSec() - truth.start_time;
    // Ground-truth pose interpolated between the 200 Hz samples.
    const size_t i = std::min(gt.size() - 2, static_cast<size_t>(std::floor(t * 200.0 + 1e-6)));
    const double f = std::min(1.0, std::max(0.0, t * 200.0 - static_cast<double>(i)));
    Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
    T_w_b.linear() = gt[i].q.slerp(f, gt[i + 1].q).toRotationMatrix();
    T_w_b.translation() = (1.0 - f) * gt[i].p + f * gt[i + 1].p;
    const Eigen::Vector3d b_predicted =
        MagnetometerSimulator::trueField(T_w_b, config.magnetometer.T_b_m, truth.magneticWorld(), t);
    const Eigen::Isometry3d T_w_m = T_w_b * config.magnetometer.T_b_m;
    const Eigen::Vector3d coil_m = T_w_m.linear().transpose() * truth.coil.field(T_w_m.translation(), t);
    const Eigen::Vector3d earth_m = T_w_m.linear().transpose() * truth.geomagnetic.fieldEnu();
    worst_residual = std::max(worst_residual, (b - b_predicted).cwiseAbs().maxCoeff());
    const Eigen::Vector3d b_without_earth = b - earth_m;
    const double w = 0.5 * (1.0 - std::cos(2.0 * M_PI * t / T));
    const std::complex<double> phasor = w * std::exp(std::complex<double>(0.0, -2.0 * M_PI * f_coil * t));
    const std::complex<double> phasor17 = w * std::exp(std::complex<double>(0.0, -2.0 * M_PI * 17.0 * t));
    for (int k = 0; k < 3; ++k) {
      measured[k] += b_without_earth[k] * phasor;
      coil_only[k] += coil_m[k] * phasor;
      off_frequency[k] += b_without_earth[k] * phasor17;
    }
    window_sum += w;
    ++n;
  }
  ASSERT_EQ(n, 19500);
  EXPECT_NEAR(magnitude_sum / n, 49e-6, 2e-6);
  EXPECT_LT(worst_residual, 6.0 * config.magnetometer.noise_std);  // measurement = truth + 5 nT noise
  auto amplitude = [&](const std::complex<double>* c) {
    double sum = 0.0;
    for (int k = 0; k < 3; ++k) sum += std::norm(2.0 * c[k] / window_sum);
    return std::sqrt(sum);
  };
  const double coil_amplitude = amplitude(coil_only);
  std::cout << "magnetometer: mean |B| " << magnitude_sum / n * 1e6 << " uT, worst residual " << worst_residual * 1e9
            << " nT, 11 Hz amplitude measured " << amplitude(measured) * 1e9 << " nT, predicted coil "
            << coil_amplitude * 1e9 << " nT, 17 Hz " << amplitude(off_frequency) * 1e9 << " nT\n";
  EXPECT_GT(coil_amplitude, 5e-9);  // the coil is measurable at 11 Hz
  EXPECT_NEAR(amplitude(measured), coil_amplitude, 0.03 * coil_amplitude + 0.3e-9);
  EXPECT_LT(amplitude(off_frequency), 0.3e-9);
}

TEST(SimulatorDeterminism, SameSeedSameBytesWhateverTheThreadCount) {
  SimOptions a = baseOptions("det_a", 3.0, 5);
  a.static_start = 1.0;
  a.render_threads = 1;
  SimOptions b = baseOptions("det_b", 3.0, 5);
  b.static_start = 1.0;
  b.name = "det_a";  // same sequence name, so the yaml/truth files can be compared byte by byte
  b.render_threads = 3;
  generate(a);
  generate(b);
  const auto pa = vims::SequencePaths::resolve(a.out_dir), pb = vims::SequencePaths::resolve(b.out_dir);
  EXPECT_EQ(serialisedMessages(pa.bag), serialisedMessages(pb.bag));
  EXPECT_EQ(readFile(pa.gt), readFile(pb.gt));
  EXPECT_EQ(readFile(pa.yaml), readFile(pb.yaml));
  EXPECT_EQ(readFile(pa.truth), readFile(pb.truth));

  // Another trajectory seed in the same world: same coil and seabed, other path and noise.
  SimOptions c = baseOptions("det_c", 3.0, 6);
  c.static_start = 1.0;
  c.world_seed = 5;
  c.lz4 = true;
  generate(c);
  const auto pc = vims::SequencePaths::resolve(c.out_dir);
  const SimTruth ta = SimTruth::load(pa.truth), tc = SimTruth::load(pc.truth);
  EXPECT_EQ(ta.coil.position_w, tc.coil.position_w);
  EXPECT_EQ(ta.geomagnetic.declination_deg, tc.geomagnetic.declination_deg);
  EXPECT_NE(readFile(pa.gt), readFile(pc.gt));
  const auto messages_c = serialisedMessages(pc.bag);  // the lz4 bag reads back
  EXPECT_EQ(messages_c.at("/imu0").size(), 600u);
  fs::remove_all(tempRoot());
}

// The default (flat, no pressure) output is byte for byte what the simulator wrote before the
// terrain and the pressure sensor existed (hashes of the files written by the simulator of
// commit 14a45fc for these options; the truth file's since it records rig_seed, 3c5dbbc's).
// Update them only when the default output is meant to change.
TEST(SimulatorDeterminism, DefaultFlatSequenceIsUnchanged) {
  SimOptions options = baseOptions("regress_dir", 3.0, 5);
  options.static_start = 1.0;
  options.name = "regress";
  generate(options);
  const auto paths = vims::SequencePaths::resolve(options.out_dir);
  EXPECT_EQ(fileHash(paths.bag), 0xb1455248f3b18949ULL);
  EXPECT_EQ(fileHash(paths.yaml), 0x35f782bc0f06c16eULL);
  EXPECT_EQ(fileHash(paths.gt), 0xccfe9632bf80b381ULL);
  EXPECT_EQ(fileHash(paths.truth), 0x1abf6be3cc0c9610ULL);
  fs::remove_all(options.out_dir);
}

// Other rates (the contract's ranges): the YAML states them and the bag follows them, so VIMS can
// be run on rigs other than the default one.
TEST(SimulatorRates, OtherRatesAreStatedAndFollowed) {
  SimOptions options = baseOptions("rates", 3.0, 5);
  options.static_start = 1.0;
  options.rates.camera = 20.0;
  options.rates.imu = 400.0;
  options.rates.sonar = 5.0;
  options.rates.magnetometer = 500.0;
  generate(options);
  const auto paths = vims::SequencePaths::resolve(options.out_dir);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths.yaml);
  EXPECT_DOUBLE_EQ(config.camera.rate_hz, 20.0);
  EXPECT_DOUBLE_EQ(config.imu.rate_hz, 400.0);
  EXPECT_DOUBLE_EQ(config.sonar.rate_hz, 5.0);
  EXPECT_DOUBLE_EQ(config.magnetometer.rate_hz, 500.0);
  const auto messages = serialisedMessages(paths.bag);
  EXPECT_NEAR(static_cast<double>(messages.at("/cam0/image_raw").size()), 60.0, 1.0);
  EXPECT_NEAR(static_cast<double>(messages.at("/imu0").size()), 1200.0, 1.0);
  EXPECT_NEAR(static_cast<double>(messages.at("/sonar/range").size()), 15.0, 1.0);
  EXPECT_NEAR(static_cast<double>(messages.at("/mag/raw").size()), 1500.0, 1.0);
  fs::remove_all(options.out_dir);
}
