#include "bag_sink.h"

#include <geometry_msgs/PoseStamped.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Range.h>

#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

namespace vims {
namespace sim {
namespace {

ros::Time toRosTime(int64_t stamp_ns) {
  ros::Time t;
  t.fromNSec(static_cast<uint64_t>(stamp_ns));
  return t;
}

}  // namespace

BagSink::BagSink(const std::string& path, bool lz4, const SequenceConfig& config, const SonarParams& sonar,
                 const ImuNoiseParams& imu, const std::string& image_format)
    : config_(config), sonar_(sonar), image_format_(image_format) {
  if (image_format_ != "raw" && image_format_ != "png" && image_format_ != "jpeg") {
    throw std::invalid_argument("BagSink: unknown image format '" + image_format_ + "'");
  }
  bag_.open(path, rosbag::bagmode::Write);
  bag_.setCompression(lz4 ? rosbag::compression::LZ4 : rosbag::compression::Uncompressed);
  // Per-sample variances of the white noise (density^2 * rate), for consumers that use them.
  gyro_variance_ = imu.gyro_noise_density * imu.gyro_noise_density * imu.rate_hz;
  accel_variance_ = imu.accel_noise_density * imu.accel_noise_density * imu.rate_hz;
}

BagSink::~BagSink() {
  try {
    close();
  } catch (...) {
    // A destructor must not throw; close() is called explicitly on the normal path.
  }
}

void BagSink::close() {
  if (bag_.isOpen()) bag_.close();
}

void BagSink::imu(int64_t stamp_ns, const ImuMeasurement& m) {
  sensor_msgs::Imu msg;
  msg.header.seq = imu_seq_++;
  msg.header.stamp = toRosTime(stamp_ns);
  msg.header.frame_id = "body";
  msg.orientation.w = 1.0;
  msg.orientation_covariance[0] = -1.0;  // no orientation estimate
  msg.angular_velocity.x = m.gyro.x();
  msg.angular_velocity.y = m.gyro.y();
  msg.angular_velocity.z = m.gyro.z();
  msg.linear_acceleration.x = m.accel.x();
  msg.linear_acceleration.y = m.accel.y();
  msg.linear_acceleration.z = m.accel.z();
  for (int i = 0; i < 3; ++i) {
    msg.angular_velocity_covariance[4 * i] = gyro_variance_;
    msg.linear_acceleration_covariance[4 * i] = accel_variance_;
  }
  bag_.write(config_.topics.imu, msg.header.stamp, msg);
}

void BagSink::image(int64_t stamp_ns, const cv::Mat& mono8) {
  if (mono8.type() != CV_8UC1) throw std::invalid_argument("BagSink::image: expected a CV_8UC1 image");
  if (image_format_ != "raw") {
    sensor_msgs::CompressedImage msg;
    msg.header.seq = image_seq_;
    msg.header.stamp = toRosTime(stamp_ns);
    msg.header.frame_id = "camera";
    msg.format = "mono8; " + image_format_ + " compressed mono8";  // as image_transport writes it
    const std::vector<int> params = image_format_ == "jpeg" ? std::vector<int>{cv::IMWRITE_JPEG_QUALITY, 95}
                                                            : std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, 3};
    if (!cv::imencode(image_format_ == "jpeg" ? ".jpg" : ".png", mono8, msg.data, params)) {
      throw std::runtime_error("BagSink: cannot encode a frame as " + image_format_);
    }
    ++image_seq_;
    bag_.write(config_.topics.image, msg.header.stamp, msg);
    return;
  }
  sensor_msgs::Image msg;
  msg.header.seq = image_seq_++;
  msg.header.stamp = toRosTime(stamp_ns);
  msg.header.frame_id = "camera";
  msg.height = static_cast<uint32_t>(mono8.rows);
  msg.width = static_cast<uint32_t>(mono8.cols);
  msg.encoding = "mono8";
  msg.is_bigendian = 0;
  msg.step = static_cast<uint32_t>(mono8.cols);
  msg.data.resize(static_cast<size_t>(mono8.rows) * mono8.cols);
  for (int r = 0; r < mono8.rows; ++r)
    std::memcpy(&msg.data[static_cast<size_t>(r) * mono8.cols], mono8.ptr(r), mono8.cols);
  bag_.write(config_.topics.image, msg.header.stamp, msg);
}

void BagSink::sonar(int64_t stamp_ns, double range) {
  sensor_msgs::Range msg;
  msg.header.seq = sonar_seq_++;
  msg.header.stamp = toRosTime(stamp_ns);
  msg.header.frame_id = "sonar";
  msg.radiation_type = sensor_msgs::Range::ULTRASOUND;
  msg.field_of_view = static_cast<float>(sonar_.field_of_view);
  msg.min_range = static_cast<float>(sonar_.min_range);
  msg.max_range = static_cast<float>(sonar_.max_range);
  msg.range = static_cast<float>(range);  // +inf stays +inf: a dropout
  bag_.write(config_.topics.sonar, msg.header.stamp, msg);
}

void BagSink::magnetometer(int64_t stamp_ns, const Eigen::Vector3d& field_m) {
  sensor_msgs::MagneticField msg;
  msg.header.seq = mag_seq_++;
  msg.header.stamp = toRosTime(stamp_ns);
  msg.header.frame_id = "mag";
  msg.magnetic_field.x = field_m.x();
  msg.magnetic_field.y = field_m.y();
  msg.magnetic_field.z = field_m.z();
  const double variance = config_.magnetometer.noise_std * config_.magnetometer.noise_std;
  for (int i = 0; i < 3; ++i) msg.magnetic_field_covariance[4 * i] = variance;
  bag_.write(config_.topics.mag, msg.header.stamp, msg);
}

void BagSink::groundTruth(int64_t stamp_ns, const Eigen::Isometry3d& T_w_b) {
  geometry_msgs::PoseStamped msg;
  msg.header.seq = pose_seq_++;
  msg.header.stamp = toRosTime(stamp_ns);
  msg.header.frame_id = "world";
  const Eigen::Quaterniond q(T_w_b.linear());
  msg.pose.position.x = T_w_b.translation().x();
  msg.pose.position.y = T_w_b.translation().y();
  msg.pose.position.z = T_w_b.translation().z();
  msg.pose.orientation.x = q.x();
  msg.pose.orientation.y = q.y();
  msg.pose.orientation.z = q.z();
  msg.pose.orientation.w = q.w();
  bag_.write(kGroundTruthTopic, msg.header.stamp, msg);
}

void BagSink::pressure(int64_t stamp_ns, double pressure_pa) {
  if (!config_.pressure) throw std::logic_error("BagSink::pressure: the sequence has no pressure sensor");
  sensor_msgs::FluidPressure msg;
  msg.header.seq = pressure_seq_++;
  msg.header.stamp = toRosTime(stamp_ns);
  msg.header.frame_id = "pressure";
  msg.fluid_pressure = pressure_pa;
  msg.variance = config_.pressure->noise_std_pa * config_.pressure->noise_std_pa;
  bag_.write(config_.topics.pressure, msg.header.stamp, msg);
}

}  // namespace sim
}  // namespace vims
