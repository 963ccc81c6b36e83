// vims_estimator_node: a thin ROS wrapper around vims::VioSystem (vims_system), the odometry that
// vims_offline runs too: per IMU sample feedImu; per image track then feedTracked; per filtered
// sonar range feedSonar; per pressure sample feedPressure; after each the outputs are taken.
// Callbacks only convert and enqueue; one processing thread makes these calls in arrival order,
// so a slow optimisation never blocks a callback.
//
// Subscribes  <topics.image of the sequence YAML> (sensor_msgs/Image, mono8/bgr8/...; or, for a topic
//                              ending in /compressed, sensor_msgs/CompressedImage, jpeg/png; others rejected)
//             <topics.imu of the sequence YAML>   (sensor_msgs/Imu)
//             sonar/filtered (vims/FilteredSonarRange): the verdicts of vims_sonar_filter_node
//             <topics.pressure of the sequence YAML> (sensor_msgs/FluidPressure), only when the
//                              sequence YAML has a pressure section (contract version 2)
// Publishes   vio/odometry      (nav_msgs/Odometry) optimised body pose at every processed frame,
//                               odom -> base_link, stamped with the image stamp
//             vio/imu_odometry  (nav_msgs/Odometry) IMU-rate pose propagated from the newest frame
//             vio/path          (nav_msgs/Path) the frame-rate poses of the current VIO session,
//                               every ~path_publish_period_s
//             vio/keyframe      (vims/Keyframe) keyframes for vims_pose_graph_node
//             vio/seabed        (visualization_msgs/Marker) the estimated local seabed plane
//                               under the vehicle (published while someone subscribes)
//             vio/sonar_hits    (visualization_msgs/Marker) the recent sonar beam hits (ditto)
//             vio/tracked_image (sensor_msgs/Image, bgr8) the image with the tracked features
//                               (drawn only while someone subscribes)
//             tf odom -> base_link (REP 105) at IMU rate (the propagated pose)
// Params      ~sequence_config (string, required): the sequence YAML (calibration, topics)
//             ~config_file     (string or list of strings, optional): system configuration files
//                              (vims::SystemConfig); the node uses the sections tracker and
//                              estimator (e.g. config/estimator.yaml); empty = the defaults
//             ~mode            (string, default full): the ablation mode as vims_offline --mode
//                              (SystemConfig::applyMode); only no_sonar concerns the VIO
//             ~image_topic, ~imu_topic, ~pressure_topic (string, optional): instead of topics.*
//             ~odom_frame_id, ~body_frame_id (string, default odom, base_link)
//             ~publish_tf (bool, default true)
//             ~queue_size (int, default 4000): inputs waiting for the processing thread (~20 s at
//                          200 Hz IMU); when full, incoming messages are dropped with a warning
//             ~path_publish_period_s (double, default 1.0)
//             ~output_dir (string, optional): writes vio.tum there at shutdown, the same file
//                         vims_offline writes (docs/offline_outputs.md)
//
// Bad input: a message the shared conversions reject (NaN IMU, unsupported image encoding, wrong
// image size, NaN range) is dropped with a throttled warning; time going backwards (a looping
// bag) is logged here, and the estimator resets and restarts a session (docs/estimator.md);
// nothing non-finite is ever published (every output passes vims_ros/odometry_conversions.h).
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <tf2_ros/transform_broadcaster.h>
#include <vims/FilteredSonarRange.h>
#include <vims/Keyframe.h>
#include <visualization_msgs/Marker.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <deque>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <variant>

#include "vims_common/config_reader.h"
#include "vims_common/sequence_config.h"
#include "vims_common/trajectory_io.h"
#include "vims_ros/bounded_queue.h"
#include "vims_ros/conversions.h"
#include "vims_ros/keyframe_conversions.h"
#include "vims_ros/node_config.h"
#include "vims_ros/odometry_conversions.h"
#include "vims_ros/ros_logger.h"
#include "vims_ros/sonar_conversions.h"
#include "vims_system/system_config.h"
#include "vims_system/vio_system.h"
#include "vims_tracking/feature_drawing.h"

namespace {

constexpr double kWarnThrottlePeriodS = 5.0;
/// [m] Side of the seabed plate drawn under the vehicle: about the camera footprint at 3 m.
constexpr double kSeabedMarkerSizeM = 3.0;
/// Sonar hits drawn: the last ~30 s at the camera rate of 10 Hz.
constexpr std::size_t kSonarHitsShown = 300;

struct NodeSettings {
  std::string image_topic;
  std::string imu_topic;
  std::string pressure_topic;
  std::string odom_frame_id = "odom";
  std::string body_frame_id = "base_link";
  bool publish_tf = true;
  int queue_size = 4000;
  double path_publish_period_s = 1.0;
  std::string output_dir;
};

/// sensor_msgs/CompressedImage is expected on a topic named <base>/compressed (image_transport).
bool isCompressedImageTopic(const std::string& topic) {
  const std::string suffix = "/compressed";
  return topic.size() > suffix.size() && topic.compare(topic.size() - suffix.size(), suffix.size(), suffix) == 0;
}

/// One input for the processing thread, in arrival order.
using InputEvent = std::variant<vims::ImuSample, vims::CameraFrame, vims::SonarFilterResult, vims::PressureSample>;

class EstimatorNode {
 public:
  EstimatorNode(ros::NodeHandle& nh, const vims::SequenceConfig& sequence, const vims::SystemConfig& config,
                NodeSettings settings)
      : sequence_(sequence),
        settings_(std::move(settings)),
        vio_(sequence, config, vims::rosLogger()),
        queue_(static_cast<std::size_t>(settings_.queue_size)) {
    if (!settings_.output_dir.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(settings_.output_dir, ec);
      vio_tum_ = std::make_unique<vims::TumWriter>((std::filesystem::path(settings_.output_dir) / "vio.tum").string());
    }
    odometry_pub_ = nh.advertise<nav_msgs::Odometry>("vio/odometry", 50);
    imu_odometry_pub_ = nh.advertise<nav_msgs::Odometry>("vio/imu_odometry", 400);
    path_pub_ = nh.advertise<nav_msgs::Path>("vio/path", 2, true);
    keyframe_pub_ = nh.advertise<vims::Keyframe>("vio/keyframe", 20);
    tracked_image_pub_ = nh.advertise<sensor_msgs::Image>("vio/tracked_image", 2);
    seabed_pub_ = nh.advertise<visualization_msgs::Marker>("vio/seabed", 2);
    sonar_hits_pub_ = nh.advertise<visualization_msgs::Marker>("vio/sonar_hits", 2);
    path_.header.frame_id = settings_.odom_frame_id;
    // Queues of the subscriptions: ~2 s of each sensor; the processing thread's own queue absorbs
    // the optimiser's latency.
    imu_sub_ = nh.subscribe(settings_.imu_topic, 400, &EstimatorNode::onImu, this, ros::TransportHints().tcpNoDelay());
    // The contract's camera topic carries raw or compressed images; image_transport names the
    // compressed one <base>/compressed.
    if (isCompressedImageTopic(settings_.image_topic)) {
      image_sub_ = nh.subscribe(settings_.image_topic, 20, &EstimatorNode::onImage<sensor_msgs::CompressedImage>, this);
    } else {
      image_sub_ = nh.subscribe(settings_.image_topic, 20, &EstimatorNode::onImage<sensor_msgs::Image>, this);
    }
    sonar_sub_ = nh.subscribe("sonar/filtered", 50, &EstimatorNode::onSonar, this);
    if (sequence_.pressure) {
      pressure_sub_ = nh.subscribe(settings_.pressure_topic, 100, &EstimatorNode::onPressure, this);
      ROS_INFO_STREAM("estimator: pressure depth from "
                      << pressure_sub_.getTopic()
                      << (config.estimator.pressure.enabled ? "" : " (estimator.pressure.enabled false: ignored)"));
    }
    worker_ = std::thread([this] { processLoop(); });
    ROS_INFO_STREAM("estimator: " << image_sub_.getTopic() << " + " << imu_sub_.getTopic() << " + "
                                  << sonar_sub_.getTopic() << " -> " << odometry_pub_.getTopic() << ", "
                                  << imu_odometry_pub_.getTopic() << ", " << path_pub_.getTopic() << ", "
                                  << keyframe_pub_.getTopic() << ", " << tracked_image_pub_.getTopic() << ", tf "
                                  << settings_.odom_frame_id << " -> " << settings_.body_frame_id
                                  << (settings_.publish_tf ? "" : " (off)") << "; use_sonar "
                                  << (config.estimator.use_sonar ? "true" : "false"));
  }

  /// End of the run (after ros::spin returned): processes what is still queued, then writes
  /// vio.tum. Reports on stderr: after SIGINT rosconsole no longer prints.
  void shutdown() {
    imu_sub_.shutdown();
    image_sub_.shutdown();
    sonar_sub_.shutdown();
    pressure_sub_.shutdown();
    queue_.close();
    if (worker_.joinable()) worker_.join();
    if (vio_tum_) {
      vio_tum_->flush();
      std::cerr << "vims_estimator: " << vio_frames_ << " poses written to " << settings_.output_dir << "/vio.tum"
                << std::endl;
    }
    if (queue_.dropped() > 0) {
      std::cerr << "vims_estimator: " << queue_.dropped() << " inputs were dropped (processing queue full)"
                << std::endl;
    }
  }

 private:
  // ---- callbacks: convert, check the clock, enqueue (never block)
  void onImu(const sensor_msgs::Imu::ConstPtr& msg) {
    vims::ImuSample sample;
    std::string why;
    if (!vims::toImuSample(*msg, &sample, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "IMU sample dropped: " << why);
      return;
    }
    checkClock(&last_imu_stamp_, sample.t, "IMU");
    enqueue(sample, "IMU sample");
  }

  template <typename ImageMsg>
  void onImage(const boost::shared_ptr<const ImageMsg>& msg) {
    vims::CameraFrame frame;
    std::string why;
    if (!vims::toCameraFrame(*msg, sequence_.camera.width, sequence_.camera.height, &frame, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "image on " << image_sub_.getTopic() << " dropped: " << why);
      return;
    }
    checkClock(&last_image_stamp_, frame.t, "image");
    enqueue(std::move(frame), "image");
  }

  void onSonar(const vims::FilteredSonarRange::ConstPtr& msg) {
    vims::SonarFilterResult result;
    std::string why;
    if (!vims::toSonarFilterResult(*msg, &result, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "filtered sonar range dropped: " << why);
      return;
    }
    enqueue(result, "sonar range");
  }

  void onPressure(const sensor_msgs::FluidPressure::ConstPtr& msg) {
    vims::PressureSample sample;
    std::string why;
    if (!vims::toPressureSample(*msg, &sample, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "pressure sample dropped: " << why);
      return;
    }
    enqueue(sample, "pressure sample");
  }

  /// The estimator resets on its own when time goes backwards; this says why in the node's log.
  static void checkClock(double* last, double t, const char* what) {
    if (t < *last) {
      ROS_WARN_STREAM(what << " time went backwards by " << (*last - t)
                           << " s (bag restarted or looped?): the estimator resets and starts a new session");
    }
    *last = t;
  }

  void enqueue(InputEvent event, const char* what) {
    if (!queue_.push(std::move(event))) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS,
                               what << " dropped: the processing queue is full (" << queue_.capacity() << " inputs; "
                                    << queue_.dropped() << " dropped so far): the estimator is slower than real time");
    }
  }

  // ---- processing thread: the same library calls, in the same order, as vims_offline
  void processLoop() {
    while (std::optional<InputEvent> event = queue_.pop()) {
      if (const auto* imu = std::get_if<vims::ImuSample>(&*event)) {
        processImu(*imu);
      } else if (const auto* frame = std::get_if<vims::CameraFrame>(&*event)) {
        processImage(*frame);
      } else if (const auto* pressure = std::get_if<vims::PressureSample>(&*event)) {
        vio_.feedPressure(*pressure);
      } else {
        vio_.feedSonar(std::get<vims::SonarFilterResult>(*event));
        drainEstimator();  // a frame waiting for this range may have been processed
      }
    }
    drainEstimator();
    publishPath(true);
  }

  void processImu(const vims::ImuSample& sample) {
    vio_.feedImu(sample);
    latest_gyro_ = sample.gyro;
    drainEstimator();
    const std::optional<vims::VioImuState> state = vio_.estimator().imuPropagatedState();
    if (!state || state->t < sample.t - 1e-9) return;  // not initialised, or no propagation to this sample
    const Eigen::Vector3d omega_b = latest_gyro_ - gyro_bias_;
    nav_msgs::Odometry odometry;
    std::string why;
    if (!vims::toOdometryMsg(state->t, state->T_odom_b, state->v_odom_b, omega_b, settings_.odom_frame_id,
                             settings_.body_frame_id, &odometry, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "IMU-rate odometry not published: " << why);
      return;
    }
    imu_odometry_pub_.publish(odometry);
    publishTf(state->t, state->T_odom_b);
  }

  void processImage(const vims::CameraFrame& frame) {
    const vims::TrackedFrame tracked = vio_.track(frame);
    vio_.feedTracked(tracked, frame.image);
    drainEstimator();
    if (tracked_image_pub_.getNumSubscribers() > 0 && tracked.accepted()) publishTrackedImage(frame, tracked);
  }

  void drainEstimator() {
    const vims::VioOutputs outputs = vio_.takeOutputs();
    for (const double t : outputs.non_finite_stamps) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "frame at t=" << t << " has a non-finite state: skipped");
    }
    for (const vims::VioFrameResult& r : outputs.poses) {
      if (vio_tum_) vims::writeVioTumRow(vio_tum_.get(), r);  // exactly as vims_offline writes it
      ++vio_frames_;
      if (r.gyro_bias.allFinite()) gyro_bias_ = r.gyro_bias;
      publishFrameResult(r);
    }
    for (const vims::KeyframeData& keyframe : outputs.keyframes) {
      vims::Keyframe msg;
      std::string why;
      if (!vims::toKeyframeMsg(keyframe, settings_.odom_frame_id, &msg, &why)) {
        ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "keyframe at t=" << keyframe.t << " not published: " << why);
        continue;
      }
      keyframe_pub_.publish(msg);
    }
  }

  void publishFrameResult(const vims::VioFrameResult& r) {
    nav_msgs::Odometry odometry;
    std::string why;
    if (!vims::toOdometryMsg(r.t_stamp, r.T_odom_b_at_stamp, r.v_odom_b, latest_gyro_ - gyro_bias_,
                             settings_.odom_frame_id, settings_.body_frame_id, &odometry, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "odometry not published: " << why);
      return;
    }
    odometry_pub_.publish(odometry);
    visualization_msgs::Marker seabed;
    if (r.seabed_height && seabed_pub_.getNumSubscribers() > 0 &&
        vims::toSeabedMarkerMsg(r.t_stamp, r.T_odom_b.translation().head<2>(), *r.seabed_height, r.seabed_slope,
                                kSeabedMarkerSizeM, settings_.odom_frame_id, &seabed, &why)) {
      seabed_pub_.publish(seabed);
    }
    if (r.sonar_hit) {
      sonar_hits_.push_back(*r.sonar_hit);
      if (sonar_hits_.size() > kSonarHitsShown) sonar_hits_.pop_front();
    }
    visualization_msgs::Marker hits;
    if (r.sonar_hit && sonar_hits_pub_.getNumSubscribers() > 0 &&
        vims::toPointsMarkerMsg(r.t_stamp, {sonar_hits_.begin(), sonar_hits_.end()}, 0.05, settings_.odom_frame_id,
                                "sonar_hits", &hits, &why)) {
      sonar_hits_pub_.publish(hits);
    }
    // The path shows one VIO session: poses of different sessions live in unrelated odom frames.
    if (path_session_ != r.session) {
      if (!path_.poses.empty()) ROS_INFO_STREAM("VIO session " << r.session << ": the VIO path starts anew");
      path_.poses.clear();
      path_session_ = r.session;
    }
    // A path's poses must be in time order: a restarted clock starts it anew.
    if (!path_.poses.empty() && odometry.header.stamp <= path_.poses.back().header.stamp) path_.poses.clear();
    geometry_msgs::PoseStamped pose;
    pose.header = odometry.header;
    pose.pose = odometry.pose.pose;
    path_.poses.push_back(pose);
    publishPath(false);
  }

  void publishPath(bool force) {
    if (path_.poses.empty()) return;
    const ros::WallTime now = ros::WallTime::now();
    if (!force && (now - last_path_publish_).toSec() < settings_.path_publish_period_s) return;
    last_path_publish_ = now;
    path_.header.stamp = path_.poses.back().header.stamp;
    path_pub_.publish(path_);
  }

  void publishTf(double t, const Eigen::Isometry3d& T_odom_b) {
    if (!settings_.publish_tf) return;
    // tf2 rejects a repeated stamp; after the clock went backwards, stamps start over.
    if (last_tf_stamp_ && t == *last_tf_stamp_) return;
    last_tf_stamp_ = t;
    geometry_msgs::TransformStamped transform;
    std::string why;
    if (!vims::toTransformMsg(t, T_odom_b, settings_.odom_frame_id, settings_.body_frame_id, &transform, &why)) {
      ROS_WARN_STREAM_THROTTLE(kWarnThrottlePeriodS, "tf not published: " << why);
      return;
    }
    tf_broadcaster_.sendTransform(transform);
  }

  void publishTrackedImage(const vims::CameraFrame& frame, const vims::TrackedFrame& tracked) {
    const cv::Mat drawn = vims::drawTrackedFeatures(frame.image, tracked);
    if (drawn.empty() || drawn.type() != CV_8UC3) return;
    sensor_msgs::Image msg;
    std::string why;
    if (!vims::toRosTime(frame.t, &msg.header.stamp, &why)) return;
    msg.header.frame_id = "camera";
    msg.height = static_cast<uint32_t>(drawn.rows);
    msg.width = static_cast<uint32_t>(drawn.cols);
    msg.encoding = "bgr8";
    msg.is_bigendian = 0;
    msg.step = static_cast<uint32_t>(drawn.cols * 3);
    msg.data.resize(static_cast<std::size_t>(msg.step) * msg.height);
    for (int r = 0; r < drawn.rows; ++r) {
      std::memcpy(msg.data.data() + static_cast<std::size_t>(r) * msg.step, drawn.ptr(r), msg.step);
    }
    tracked_image_pub_.publish(msg);
  }

  const vims::SequenceConfig sequence_;
  const NodeSettings settings_;
  // Used by the processing thread only (after construction).
  vims::VioSystem vio_;
  std::unique_ptr<vims::TumWriter> vio_tum_;
  long vio_frames_ = 0;
  Eigen::Vector3d latest_gyro_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_ = Eigen::Vector3d::Zero();
  nav_msgs::Path path_;
  std::optional<std::uint32_t> path_session_;
  ros::WallTime last_path_publish_;
  std::optional<double> last_tf_stamp_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  // Used by the callbacks only (one spinner thread).
  double last_imu_stamp_ = -1e300;
  double last_image_stamp_ = -1e300;

  vims::BoundedQueue<InputEvent> queue_;
  std::thread worker_;
  ros::Publisher odometry_pub_, imu_odometry_pub_, path_pub_, keyframe_pub_, tracked_image_pub_, seabed_pub_,
      sonar_hits_pub_;
  std::deque<Eigen::Vector3d> sonar_hits_;  ///< the latest kSonarHitsShown beam hits (VIO frame)
  ros::Subscriber imu_sub_, image_sub_, sonar_sub_, pressure_sub_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "vims_estimator");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  std::string sequence_path, mode;
  if (!pnh.getParam("sequence_config", sequence_path)) {
    ROS_FATAL("parameter ~sequence_config (path of the sequence YAML) is required");
    return 1;
  }
  pnh.param<std::string>("mode", mode, "full");
  NodeSettings settings;
  pnh.param<std::string>("odom_frame_id", settings.odom_frame_id, settings.odom_frame_id);
  pnh.param<std::string>("body_frame_id", settings.body_frame_id, settings.body_frame_id);
  pnh.param("publish_tf", settings.publish_tf, settings.publish_tf);
  pnh.param("queue_size", settings.queue_size, settings.queue_size);
  pnh.param("path_publish_period_s", settings.path_publish_period_s, settings.path_publish_period_s);
  pnh.param<std::string>("output_dir", settings.output_dir, "");
  if (settings.queue_size <= 0) {
    ROS_FATAL_STREAM("parameter ~queue_size must be > 0 (is " << settings.queue_size << ")");
    return 1;
  }
  if (!(settings.path_publish_period_s >= 0.0) || !std::isfinite(settings.path_publish_period_s)) {
    ROS_FATAL_STREAM("parameter ~path_publish_period_s must be >= 0 (is " << settings.path_publish_period_s << ")");
    return 1;
  }

  std::unique_ptr<EstimatorNode> node;
  try {
    std::vector<std::string> unknown;
    const vims::SequenceConfig sequence = vims::SequenceConfig::load(sequence_path, &unknown);
    for (const auto& key : unknown) ROS_WARN_STREAM(sequence_path << ": key '" << key << "' is not in the contract");
    vims::SystemConfig config = vims::SystemConfig::load(vims::configFilesParam(pnh), sequence);
    config.applyMode(mode);
    settings.image_topic = pnh.param<std::string>("image_topic", sequence.topics.image);
    settings.imu_topic = pnh.param<std::string>("imu_topic", sequence.topics.imu);
    settings.pressure_topic = pnh.param<std::string>("pressure_topic", sequence.topics.pressure);
    ROS_INFO_STREAM("tracker options:\n"
                    << config.tracker.toYaml() << "\nestimator options:\n"
                    << config.estimator.toYaml());
    node = std::make_unique<EstimatorNode>(nh, sequence, config, settings);
  } catch (const vims::ConfigError& e) {
    ROS_FATAL_STREAM("configuration error: " << e.what());
    return 1;
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("cannot start the estimator: " << e.what());
    return 1;
  }
  ros::spin();
  node->shutdown();
  return 0;
}
