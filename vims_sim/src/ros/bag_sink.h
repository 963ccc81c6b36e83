#pragma once
/// @file bag_sink.h
/// @brief ROS glue of the simulator: writes the generated messages into a rosbag following
/// docs/sensor-contract.md (topics from the sequence config, frame ids camera/body/sonar/mag/
/// pressure, world for the ground truth).

#include <rosbag/bag.h>

#include <string>

#include "vims_common/sequence_config.h"
#include "vims_sim/sequence_generator.h"

namespace vims {
namespace sim {

class BagSink : public SimSink {
 public:
  /// Opens `path` for writing (throws rosbag::BagException on failure).
  /// `image_format`: "raw" (sensor_msgs/Image mono8), "png" or "jpeg" (sensor_msgs/CompressedImage).
  BagSink(const std::string& path, bool lz4, const SequenceConfig& config, const SonarParams& sonar,
          const ImuNoiseParams& imu, const std::string& image_format = "raw");
  ~BagSink() override;

  void imu(int64_t stamp_ns, const ImuMeasurement& measurement) override;
  void image(int64_t stamp_ns, const cv::Mat& mono8) override;
  void sonar(int64_t stamp_ns, double range) override;
  void magnetometer(int64_t stamp_ns, const Eigen::Vector3d& field_m) override;
  void groundTruth(int64_t stamp_ns, const Eigen::Isometry3d& T_w_b) override;
  void pressure(int64_t stamp_ns, double pressure_pa) override;

  /// Flushes and closes the bag (also done by the destructor).
  void close();

  static constexpr const char* kGroundTruthTopic = "/ground_truth/pose";

 private:
  rosbag::Bag bag_;
  SequenceConfig config_;
  SonarParams sonar_;
  std::string image_format_;
  double gyro_variance_;
  double accel_variance_;
  uint32_t image_seq_ = 0, imu_seq_ = 0, sonar_seq_ = 0, mag_seq_ = 0, pose_seq_ = 0, pressure_seq_ = 0;
};

}  // namespace sim
}  // namespace vims
