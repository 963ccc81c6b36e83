// vims_magnetometer_node: a thin ROS wrapper around vims::MagneticFrontEnd (the SignatureExtractor,
// after a search for the coil frequency when the sequence leaves it open).
//
// Subscribes  <topics.mag of the sequence YAML> (sensor_msgs/MagneticField, default /mag/raw)
//             <topics.imu of the sequence YAML> (sensor_msgs/Imu, default /imu0): the extractor's
//             own AHRS needs gyro and accelerometer to rotate the alternating field into ENU
// Publishes   mag/signature   (vims/MagneticSignature) one per window (every hop_s), valid or not
//             mag/geomagnetic (sensor_msgs/MagneticField) the low-passed geomagnetic field in the
//                             body frame, every geomagnetic_output_period_s, for yaw factors
// Params      ~sequence_config (string, required): the sequence YAML (T_b_m, rate, coil frequency,
//                              declination, gravity, topics)
//             ~config_file     (string or list of strings, optional): system configuration files
//                              (vims::SystemConfig); the node uses the section magnetometer
//                              (e.g. config/magnetometer.yaml); empty = the defaults
//             ~mag_topic, ~imu_topic (string, optional): input topics instead of topics.mag / topics.imu
//             ~world_frame_id  (string, default "map"): frame_id of the signatures (true ENU)
//             ~body_frame_id   (string, default "base_link"): frame_id of the geomagnetic vector
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <vims/MagneticSignature.h>

#include <cmath>

#include "vims_common/config_reader.h"
#include "vims_common/sequence_config.h"
#include "vims_magnetometer/magnetic_front_end.h"
#include "vims_ros/conversions.h"
#include "vims_ros/node_config.h"
#include "vims_ros/ros_logger.h"
#include "vims_system/system_config.h"

namespace {

/// Non-finite entries become 0 (returns false when there were any).
bool zeroNonFinite(Eigen::Vector3d* v) {
  bool finite = true;
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite((*v)[i])) {
      (*v)[i] = 0.0;
      finite = false;
    }
  }
  return finite;
}

bool zeroNonFinite(double* x) {
  if (std::isfinite(*x)) return true;
  *x = 0.0;
  return false;
}

geometry_msgs::Vector3 toVector3(const Eigen::Vector3d& v) {
  geometry_msgs::Vector3 out;
  out.x = v.x();
  out.y = v.y();
  out.z = v.z();
  return out;
}

class MagnetometerNode {
 public:
  MagnetometerNode(ros::NodeHandle& nh, const vims::SequenceConfig& sequence, const vims::MagnetometerOptions& options,
                   const std::string& mag_topic, const std::string& imu_topic, std::string world_frame,
                   std::string body_frame)
      : front_end_(options, sequence.magnetometer, sequence.imu.gravity, vims::rosLogger()),
        world_frame_(std::move(world_frame)),
        body_frame_(std::move(body_frame)) {
    signature_pub_ = nh.advertise<vims::MagneticSignature>("mag/signature", 20);
    geomagnetic_pub_ = nh.advertise<sensor_msgs::MagneticField>("mag/geomagnetic", 50);
    // Queues hold ~2 s of data: the magnetometer runs at 1000 Hz and must not lose samples
    // (a lost sample invalidates the windows around it).
    mag_sub_ = nh.subscribe(mag_topic, 2000, &MagnetometerNode::onMag, this, ros::TransportHints().tcpNoDelay());
    imu_sub_ = nh.subscribe(imu_topic, 400, &MagnetometerNode::onImu, this, ros::TransportHints().tcpNoDelay());
    ROS_INFO_STREAM("magnetometer: " << mag_sub_.getTopic() << " + " << imu_sub_.getTopic() << " -> "
                                     << signature_pub_.getTopic() << ", " << geomagnetic_pub_.getTopic()
                                     << "; options:\n"
                                     << options.toYaml());
  }

 private:
  void onImu(const sensor_msgs::Imu::ConstPtr& msg) {
    vims::ImuSample sample;
    std::string why;
    if (!vims::toImuSample(*msg, &sample, &why)) {
      ROS_WARN_STREAM_THROTTLE(5.0, "IMU message rejected: " << why);
      return;
    }
    front_end_.feedImu(sample);
  }

  void onMag(const sensor_msgs::MagneticField::ConstPtr& msg) {
    vims::MagSample sample;
    std::string why;
    if (!vims::toMagSample(*msg, &sample, &why)) {
      // The extractor sees the hole as a gap and invalidates the windows around it.
      ROS_WARN_STREAM_THROTTLE(5.0, "magnetometer message rejected: " << why);
      return;
    }
    signatures_.clear();
    geomagnetic_.clear();
    front_end_.feedMag(sample, &signatures_, &geomagnetic_);
    // Nothing non-finite leaves the node: a geomagnetic sample with NaN/Inf (extreme input can
    // overflow the averages) is dropped; a signature's non-finite values become 0 and the window
    // is marked invalid (it carries no measurement then, as vims::toSignatureWindow reads it).
    for (const vims::GeomagneticSample& g : geomagnetic_) {
      if (!g.field_b.allFinite() || !std::isfinite(g.std_per_axis)) {
        ROS_WARN_STREAM_THROTTLE(5.0, "non-finite geomagnetic field at t=" << g.t << " not published");
        continue;
      }
      sensor_msgs::MagneticField out;
      out.header.stamp = ros::Time(g.t);
      out.header.frame_id = body_frame_;
      out.magnetic_field = toVector3(g.field_b);
      const double var = g.std_per_axis * g.std_per_axis;
      out.magnetic_field_covariance = {var, 0, 0, 0, var, 0, 0, 0, var};
      geomagnetic_pub_.publish(out);
    }
    for (vims::SignatureWindow& s : signatures_) {
      bool finite = zeroNonFinite(&s.amplitude_enu);
      finite = zeroNonFinite(&s.geomagnetic_body) && finite;
      finite = zeroNonFinite(&s.snr) && finite;
      finite = zeroNonFinite(&s.frequency_hz) && finite;
      if (!finite) {
        ROS_WARN_STREAM_THROTTLE(5.0,
                                 "signature window at t=" << s.t << " has non-finite values: published as invalid");
        s.valid = false;
      }
      vims::MagneticSignature out;
      out.header.stamp = ros::Time(s.t);
      out.header.frame_id = world_frame_;
      out.window_start = ros::Time(s.t_start);
      out.window_end = ros::Time(s.t_end);
      out.coil = static_cast<uint8_t>(s.coil);
      out.frequency_hz = s.frequency_hz;
      out.amplitude_enu = toVector3(s.amplitude_enu);
      out.geomagnetic_body = toVector3(s.geomagnetic_body);
      out.snr = s.snr;
      out.valid = s.valid;
      signature_pub_.publish(out);
    }
  }

  vims::MagneticFrontEnd front_end_;
  std::string world_frame_;
  std::string body_frame_;
  std::vector<vims::SignatureWindow> signatures_;
  std::vector<vims::GeomagneticSample> geomagnetic_;
  ros::Publisher signature_pub_;
  ros::Publisher geomagnetic_pub_;
  ros::Subscriber mag_sub_;
  ros::Subscriber imu_sub_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "vims_magnetometer");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string sequence_path, world_frame, body_frame;
  if (!pnh.getParam("sequence_config", sequence_path)) {
    ROS_FATAL("parameter ~sequence_config (path of the sequence YAML) is required");
    return 1;
  }
  pnh.param<std::string>("world_frame_id", world_frame, "map");
  pnh.param<std::string>("body_frame_id", body_frame, "base_link");
  try {
    std::vector<std::string> unknown;
    const vims::SequenceConfig sequence = vims::SequenceConfig::load(sequence_path, &unknown);
    for (const auto& key : unknown) ROS_WARN_STREAM(sequence_path << ": key '" << key << "' is not in the contract");
    const vims::SystemConfig config = vims::SystemConfig::load(vims::configFilesParam(pnh), sequence);
    MagnetometerNode node(nh, sequence, config.magnetometer, pnh.param<std::string>("mag_topic", sequence.topics.mag),
                          pnh.param<std::string>("imu_topic", sequence.topics.imu), world_frame, body_frame);
    ros::spin();
  } catch (const vims::ConfigError& e) {
    ROS_FATAL_STREAM("configuration error: " << e.what());
    return 1;
  }
  return 0;
}
