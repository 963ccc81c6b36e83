// rostest node for test/robustness/robustness.test (issue 6): publishes 10 000 malformed or
// hostile messages at every topic the VIMS nodes subscribe to (NaN/Inf fields, absurd values,
// wrong image encodings, empty images, sizes that do not match the data, keyframes with NaN or
// inconsistent fields, stamps that are zero, repeated, out of order or jumping back), while
// listening to every topic the nodes publish. Then checks that
//   - no published message holds a NaN or Inf,
//   - every node is still alive (answers its XML-RPC API, its process exists),
//   - the front ends and the pose graph still work: fed good data afterwards, they publish it.
// The nodes run in namespaces (robustness.test) so the hostile inputs never mix with the outputs.
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <nav_msgs/Path.h>
#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Range.h>
#include <signal.h>
#include <sys/types.h>
#include <tf2_msgs/TFMessage.h>
#include <vims/FilteredSonarRange.h>
#include <vims/Keyframe.h>
#include <vims/MagneticSignature.h>
#include <visualization_msgs/Marker.h>
#include <visualization_msgs/MarkerArray.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <random>
#include <string>
#include <vector>

namespace {

constexpr int kMessagesPerTopic = 10000;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
/// Bag-clock time of the hostile stream's start, and of the good data afterwards (later than
/// every hostile stamp, so the nodes' clocks move forward again).
constexpr double kStart = 1.0e6;
constexpr double kRecover = 2.0e6;

// ---- finiteness of every floating-point field of the published types ----
bool finite(double x) { return std::isfinite(x); }
bool finite(const geometry_msgs::Vector3& v) { return finite(v.x) && finite(v.y) && finite(v.z); }
bool finite(const geometry_msgs::Point& p) { return finite(p.x) && finite(p.y) && finite(p.z); }
bool finite(const geometry_msgs::Quaternion& q) { return finite(q.x) && finite(q.y) && finite(q.z) && finite(q.w); }
bool finite(const geometry_msgs::Pose& p) { return finite(p.position) && finite(p.orientation); }
template <std::size_t N>
bool finite(const boost::array<double, N>& a) {
  for (double x : a)
    if (!finite(x)) return false;
  return true;
}
bool finite(const geometry_msgs::Twist& t) { return finite(t.linear) && finite(t.angular); }
bool finite(const nav_msgs::Odometry& m) {
  return finite(m.pose.pose) && finite(m.pose.covariance) && finite(m.twist.twist) && finite(m.twist.covariance);
}
bool finite(const nav_msgs::Path& m) {
  for (const auto& p : m.poses)
    if (!finite(p.pose)) return false;
  return true;
}
/// raw may be +inf (no echo, REP 117), never NaN.
bool finite(const vims::FilteredSonarRange& m) { return finite(m.filtered) && !std::isnan(m.raw); }
bool finite(const sensor_msgs::MagneticField& m) {
  return finite(m.magnetic_field) && finite(m.magnetic_field_covariance);
}
bool finite(const vims::MagneticSignature& m) {
  return finite(m.frequency_hz) && finite(m.amplitude_enu) && finite(m.geomagnetic_body) && finite(m.snr);
}
bool finite(const std_msgs::ColorRGBA& c) { return finite(c.r) && finite(c.g) && finite(c.b) && finite(c.a); }
bool finite(const visualization_msgs::Marker& m) {
  if (!finite(m.pose) || !finite(m.scale) || !finite(m.color)) return false;
  for (const auto& p : m.points)
    if (!finite(p)) return false;
  for (const auto& c : m.colors)
    if (!finite(c)) return false;
  return true;
}
bool finite(const visualization_msgs::MarkerArray& m) {
  for (const auto& marker : m.markers)
    if (!finite(marker)) return false;
  return true;
}
bool finite(const tf2_msgs::TFMessage& m) {
  for (const auto& t : m.transforms)
    if (!finite(t.transform.translation) || !finite(t.transform.rotation)) return false;
  return true;
}
bool finite(const vims::Keyframe& m) {
  if (!finite(m.pose)) return false;
  for (const auto& f : m.features)
    if (!finite(f.p_odom) || !finite(f.u) || !finite(f.v) || !finite(f.x_norm) || !finite(f.y_norm)) return false;
  return true;
}

/// Counts the messages of one output topic and those holding a NaN/Inf.
class OutputMonitor {
 public:
  template <class M>
  void watch(ros::NodeHandle& nh, const std::string& topic) {
    Stream& stream = streams_[topic];
    stream.topic = topic;
    subscribers_.push_back(nh.subscribe<M>(topic, 10000, [this, topic](const boost::shared_ptr<const M>& msg) {
      const bool ok = finite(*msg);
      std::lock_guard<std::mutex> lock(mutex_);
      Stream& s = streams_[topic];
      ++s.messages;
      if (!ok) ++s.nonfinite;
      last_stamp_[topic] = stampOf(*msg);
    }));
  }
  int messages(const std::string& topic) {
    std::lock_guard<std::mutex> lock(mutex_);
    return streams_[topic].messages;
  }
  double lastStamp(const std::string& topic) {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_stamp_.count(topic) ? last_stamp_[topic] : 0.0;
  }
  void expectAllFinite() {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [topic, s] : streams_) {
      EXPECT_EQ(s.nonfinite, 0) << topic << ": " << s.nonfinite << " of " << s.messages
                                << " published messages hold NaN or Inf";
      std::cout << "output " << topic << ": " << s.messages << " messages, " << s.nonfinite << " non-finite\n";
    }
  }
  const std::vector<ros::Subscriber>& subscribers() const { return subscribers_; }

 private:
  struct Stream {
    std::string topic;
    int messages = 0;
    int nonfinite = 0;
  };
  template <class M>
  static double stampOf(const M& m) {
    if constexpr (ros::message_traits::HasHeader<M>::value) {
      return m.header.stamp.toSec();
    } else {
      return 0.0;
    }
  }
  std::mutex mutex_;
  std::map<std::string, Stream> streams_;
  std::map<std::string, double> last_stamp_;
  std::vector<ros::Subscriber> subscribers_;
};

// ---- hostile inputs ----

/// Stamps: mostly a steady clock at `rate_hz`, with zero stamps, repeats, swaps (out of order)
/// and jumps back by 50 s mixed in.
ros::Time hostileStamp(int i, double rate_hz) {
  const double nominal = kStart + i / rate_hz;
  switch (i % 10) {
    case 3:
      return ros::Time(0, 0);
    case 5:
      return ros::Time(nominal - 50.0);
    case 7:
      return ros::Time(kStart + (i - 1) / rate_hz);  // the previous message's stamp
    case 8:
      return ros::Time(nominal + 1.0 / rate_hz);  // swapped with the next one
    case 9:
      return ros::Time(nominal - 1.0 / rate_hz);
    default:
      return ros::Time(nominal);
  }
}

/// A filter verdict as vims_sonar_filter_node would publish it, or one that breaks its rules.
vims::FilteredSonarRange hostileFilteredRange(int i, std::mt19937& rng) {
  vims::FilteredSonarRange m;
  m.header.stamp = hostileStamp(i, 10.0);
  m.header.frame_id = "sonar";
  std::normal_distribution<double> noise(0.0, 0.02);
  m.raw = m.filtered = 3.0 + noise(rng);
  m.has_estimate = m.accepted = true;
  m.status = vims::FilteredSonarRange::STATUS_OK;
  switch (i % 11) {
    case 0:
      m.filtered = std::numeric_limits<double>::quiet_NaN();
      break;
    case 1:
      m.raw = std::numeric_limits<double>::quiet_NaN();
      break;
    case 2:
      m.filtered = -1.0;
      break;
    case 3:
      m.filtered = 1e30;
      break;  // finite but absurd
    case 4:
      m.status = 200;
      break;
    case 5:
      m.has_estimate = false;
      break;  // accepted without an estimate
    case 6:
      m.accepted = false;
      m.status = vims::FilteredSonarRange::STATUS_OUTLIER;
      break;
    case 7:
      m.filtered = std::numeric_limits<double>::infinity();
      break;
    default:
      break;
  }
  return m;
}

sensor_msgs::Range hostileRange(int i, std::mt19937& rng) {
  sensor_msgs::Range m;
  m.header.stamp = hostileStamp(i, 10.0);
  m.header.frame_id = "sonar";
  m.radiation_type = sensor_msgs::Range::ULTRASOUND;
  m.field_of_view = 0.1f;
  m.min_range = 0.1f;
  m.max_range = 50.0f;
  std::normal_distribution<float> noise(0.0f, 0.02f);
  m.range = 3.0f + noise(rng);
  switch (i % 13) {
    case 0:
      m.range = std::numeric_limits<float>::quiet_NaN();
      break;
    case 1:
      m.range = std::numeric_limits<float>::infinity();
      break;
    case 2:
      m.range = -std::numeric_limits<float>::infinity();
      break;
    case 3:
      m.range = -1.0f;
      break;
    case 4:
      m.range = 0.0f;
      break;
    case 5:
      m.range = 1e30f;
      break;
    case 6:  // a good range in a message whose sensor fields are NaN
      m.field_of_view = m.min_range = m.max_range = std::numeric_limits<float>::quiet_NaN();
      break;
    case 7:
      m.max_range = std::numeric_limits<float>::infinity();
      m.min_range = -1.0f;
      break;
    default:
      break;
  }
  return m;
}

sensor_msgs::Imu hostileImu(int i, std::mt19937& rng) {
  sensor_msgs::Imu m;
  m.header.stamp = hostileStamp(i, 200.0);
  m.header.frame_id = "body";
  std::normal_distribution<double> noise(0.0, 0.01);
  m.angular_velocity.x = noise(rng);
  m.angular_velocity.y = noise(rng);
  m.angular_velocity.z = noise(rng);
  m.linear_acceleration.x = noise(rng);
  m.linear_acceleration.y = noise(rng);
  m.linear_acceleration.z = 9.81 + noise(rng);
  m.orientation_covariance[0] = -1.0;
  switch (i % 11) {
    case 0:
      m.angular_velocity.y = kNaN;
      break;
    case 1:
      m.linear_acceleration.z = kInf;
      break;
    case 2:
      m.linear_acceleration.x = 1e30;
      m.angular_velocity.z = -1e30;
      break;
    case 3:  // good rates, garbage in the fields VIMS does not use
      m.orientation.x = kNaN;
      m.orientation_covariance[0] = kNaN;
      m.angular_velocity_covariance[4] = kInf;
      break;
    case 4:
      m.linear_acceleration.x = m.linear_acceleration.y = m.linear_acceleration.z = 0.0;
      break;  // free fall
    default:
      break;
  }
  return m;
}

sensor_msgs::MagneticField hostileMag(int i, double rate_hz, std::mt19937& rng) {
  sensor_msgs::MagneticField m;
  m.header.stamp = hostileStamp(i, rate_hz);
  m.header.frame_id = "mag";
  std::normal_distribution<double> noise(0.0, 5e-9);
  const double coil = 2e-6 * std::sin(2.0 * M_PI * 11.0 * i / rate_hz);
  m.magnetic_field.x = 2e-5 + noise(rng);
  m.magnetic_field.y = 1e-6 + noise(rng);
  m.magnetic_field.z = -4e-5 + coil + noise(rng);
  switch (i % 7) {
    case 0:
      m.magnetic_field.x = kNaN;
      break;
    case 1:
      m.magnetic_field.z = -kInf;
      break;
    case 2:
      m.magnetic_field.y = 1e10;
      break;
    case 3:
      m.magnetic_field.x = m.magnetic_field.y = m.magnetic_field.z = 0.0;
      break;
    case 4:
      m.magnetic_field_covariance[0] = kNaN;
      break;
    default:
      break;
  }
  return m;
}

/// A mono8 image of noise, `width` x `height` (drawn once per size: the stream stays fast).
sensor_msgs::Image noiseImage(uint32_t width, uint32_t height, std::mt19937& rng) {
  static std::map<std::pair<uint32_t, uint32_t>, std::vector<uint8_t>> cache;
  std::vector<uint8_t>& pixels = cache[{width, height}];
  if (pixels.empty()) {
    pixels.resize(static_cast<std::size_t>(width) * height);
    std::uniform_int_distribution<int> grey(0, 255);
    for (auto& px : pixels) px = static_cast<uint8_t>(grey(rng));
  }
  sensor_msgs::Image m;
  m.width = width;
  m.height = height;
  m.encoding = "mono8";
  m.step = width;
  m.data = pixels;
  return m;
}

/// Malformed images; one in 12 is a well-formed image of the calibration's size (so that the
/// stamp anomalies reach the tracker and the VIO).
sensor_msgs::Image hostileImage(int i, int width, int height, std::mt19937& rng) {
  sensor_msgs::Image m;
  switch (i % 12) {
    case 0:
      m = noiseImage(64, 48, rng);
      m.encoding = "rgb16";
      break;
    case 1: {  // float image with NaN pixels
      m.width = 64, m.height = 48, m.encoding = "32FC1", m.step = 64 * 4;
      std::vector<float> px(64 * 48, std::numeric_limits<float>::quiet_NaN());
      m.data.resize(px.size() * 4);
      std::memcpy(m.data.data(), px.data(), m.data.size());
      break;
    }
    case 2:
      m = noiseImage(width, height, rng);
      m.encoding = "bayer_rggb8";
      break;
    case 3:
      m.encoding = "mono8";
      break;  // empty: 0 x 0, no data
    case 4:
      m.width = width, m.height = height, m.encoding = "mono8", m.step = width, m.data.resize(100);
      break;
    case 5:
      m = noiseImage(width, height, rng);
      m.step = 10;
      break;  // step shorter than a row
    case 6:
      m = noiseImage(64, 48, rng);
      break;  // not the calibration's size
    case 7:
      m = noiseImage(width, height, rng);
      m.encoding = "mono16";
      m.is_bigendian = 1;
      break;
    case 8:
      m = noiseImage(64, 48, rng);
      m.encoding = "";
      break;
    case 9:
      m = noiseImage(width, height, rng);
      m.encoding = "bgr8";
      break;  // data is a third of a bgr8 image
    case 10:
      m = noiseImage(width, height, rng);
      break;  // well formed
    case 11:
      m.width = 65535, m.height = 65535, m.encoding = "mono8", m.step = 65535, m.data.resize(16);
      break;
  }
  m.header.stamp = hostileStamp(i, 10.0);
  m.header.frame_id = "camera";
  return m;
}

geometry_msgs::Pose goodPose(int i) {
  geometry_msgs::Pose p;
  p.position.x = 0.01 * i;
  p.position.y = std::sin(0.01 * i);
  p.position.z = -3.0;
  const double yaw = 0.001 * i;
  p.orientation.z = std::sin(yaw / 2);
  p.orientation.w = std::cos(yaw / 2);
  return p;
}

/// Keyframes for the pose graph: NaN and non-unit poses, NaN features, bad images, and
/// well-formed ones (empty image: a node without visual submap; sometimes an image of noise with
/// features) with the hostile stamps and jumping session numbers.
vims::Keyframe hostileKeyframe(int i, int width, int height, std::mt19937& rng) {
  vims::Keyframe m;
  m.header.stamp = hostileStamp(i, 2.0);
  m.header.frame_id = "odom";
  m.session = static_cast<uint32_t>(i / 1000);
  m.pose = goodPose(i);
  std::uniform_real_distribution<float> pixel(0.0f, 600.0f);
  for (int k = 0; k < 30; ++k) {
    vims::KeyframeFeature f;
    f.id = static_cast<uint64_t>(i) * 100 + k;
    f.p_odom.x = 0.1 * k;
    f.p_odom.y = 0.05 * k;
    f.p_odom.z = -6.0;
    f.u = pixel(rng);
    f.v = pixel(rng) * 0.75f;
    f.x_norm = (f.u - 320.0f) / 420.0f;
    f.y_norm = (f.v - 240.0f) / 420.0f;
    m.features.push_back(f);
  }
  switch (i % 14) {
    case 0:
      m.pose.position.y = kNaN;
      break;
    case 1:
      m.pose.orientation = geometry_msgs::Quaternion();
      m.pose.orientation.w = 0.0;
      break;
    case 2:
      m.pose.orientation.w = 2.0;
      break;
    case 3:
      m.features[3].p_odom.z = kNaN;
      break;
    case 4:
      m.features[5].u = std::numeric_limits<float>::infinity();
      break;
    case 5:
      m.image = noiseImage(64, 48, rng);
      m.image.encoding = "rgb16";
      break;
    case 6:
      m.image = noiseImage(64, 48, rng);
      m.image.height = 480;
      break;  // data does not match the size
    case 7:
      m.features.clear();
      break;  // empty image, no features
    case 8:
      m.features[0].x_norm = 1e30f;
      m.features[1].p_odom.x = 1e30;
      break;  // finite but absurd
    case 9:
      m.session = static_cast<uint32_t>(i);
      break;  // a new session every time
    case 10:
      if (i % 140 == 10) m.image = noiseImage(width, height, rng);  // described with ORB: kept rare (slow)
      break;
    case 11:
      m.image = noiseImage(width, height, rng);
      m.image.encoding = "32FC1";
      break;
    case 12:
      for (auto& f : m.features) f.id = 7;
      break;  // duplicate feature ids
    default:
      break;
  }
  return m;
}

vims::MagneticSignature hostileSignature(int i) {
  vims::MagneticSignature m;
  m.header.stamp = hostileStamp(i, 2.5);
  m.header.frame_id = "map";
  m.window_start = ros::Time(std::max(0.0, m.header.stamp.toSec() - 1.0));
  m.window_end = ros::Time(m.header.stamp.toSec() + 1.0);
  m.frequency_hz = 11.0;
  m.amplitude_enu.x = 1e-7 * std::sin(0.01 * i);
  m.amplitude_enu.y = 2e-7;
  m.amplitude_enu.z = 1e-6 * (1.0 + 0.5 * std::cos(0.003 * i));
  m.geomagnetic_body.x = 2e-5;
  m.geomagnetic_body.z = -4e-5;
  m.snr = 50.0;
  m.valid = true;
  switch (i % 9) {
    case 0:
      m.amplitude_enu.x = kNaN;
      break;
    case 1:
      m.amplitude_enu.y = kNaN;
      m.snr = kNaN;
      m.valid = false;
      break;
    case 2:
      m.snr = kInf;
      break;
    case 3:
      m.frequency_hz = kNaN;
      break;
    case 4:
      std::swap(m.window_start, m.window_end);
      break;
    case 5:
      m.window_start = m.window_end = ros::Time(0, 0);
      break;
    case 6:
      m.geomagnetic_body.x = m.geomagnetic_body.y = m.geomagnetic_body.z = 0.0;
      break;
    default:
      break;
  }
  return m;
}

sensor_msgs::MagneticField hostileGeomagnetic(int i) {
  sensor_msgs::MagneticField m;
  m.header.stamp = hostileStamp(i, 10.0);
  m.header.frame_id = "base_link";
  m.magnetic_field.x = 2e-5 * std::cos(0.001 * i);
  m.magnetic_field.y = 2e-5 * std::sin(0.001 * i);
  m.magnetic_field.z = -4e-5;
  switch (i % 6) {
    case 0:
      m.magnetic_field.y = kNaN;
      break;
    case 1:
      m.magnetic_field.x = kInf;
      break;
    case 2:
      m.magnetic_field.x = m.magnetic_field.y = m.magnetic_field.z = 0.0;
      break;  // no direction
    case 3:
      m.magnetic_field.z = 1e10;
      break;
    default:
      break;
  }
  return m;
}

nav_msgs::Odometry hostileOdometry(int i) {
  nav_msgs::Odometry m;
  m.header.stamp = hostileStamp(i, 10.0);
  m.header.frame_id = "odom";
  m.child_frame_id = "base_link";
  m.pose.pose = goodPose(i);
  m.pose.covariance[0] = m.pose.covariance[7] = m.pose.covariance[14] = 0.01;
  m.twist.twist.linear.x = 0.3;
  switch (i % 8) {
    case 0:
      m.pose.pose.position.x = kNaN;
      break;
    case 1:
      m.pose.pose.orientation = geometry_msgs::Quaternion();
      m.pose.pose.orientation.w = 0.0;
      break;
    case 2:
      m.pose.pose.orientation.x = 1.0;
      break;  // norm sqrt(2)
    case 3:
      m.pose.covariance[7] = kNaN;
      break;  // good pose, NaN covariance
    case 4:
      m.twist.twist.angular.z = kNaN;
      break;  // good pose, NaN twist
    case 5:
      m.twist.twist.linear.y = kInf;
      m.twist.covariance[0] = kInf;
      break;
    default:
      break;
  }
  return m;
}

/// True when the node answers getPid on its XML-RPC API and that process exists.
bool nodeAlive(const std::string& name, std::string* why) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = name;
  if (!ros::master::execute("lookupNode", args, result, payload, false) ||
      result.getType() != XmlRpc::XmlRpcValue::TypeArray || static_cast<int>(result[0]) != 1) {
    *why = "the master does not know it";
    return false;
  }
  const std::string uri = static_cast<std::string>(result[2]);
  std::string host, path;
  uint32_t port = 0;
  if (!ros::network::splitURI(uri, host, port)) {
    *why = "bad URI " + uri;
    return false;
  }
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue pid_args, pid_result;
  pid_args[0] = ros::this_node::getName();
  if (!client.execute("getPid", pid_args, pid_result) || pid_result.getType() != XmlRpc::XmlRpcValue::TypeArray ||
      static_cast<int>(pid_result[0]) != 1) {
    *why = "no answer from " + uri;
    return false;
  }
  const int pid = static_cast<int>(pid_result[2]);
  if (::kill(pid, 0) != 0) {
    *why = "process " + std::to_string(pid) + " is gone";
    return false;
  }
  return true;
}

template <class Predicate>
bool waitFor(Predicate done, double timeout_s) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && !done()) {
    if (ros::WallTime::now() > deadline) return false;
    ros::WallDuration(0.02).sleep();
  }
  return true;
}

}  // namespace

TEST(NodeRobustness, MalformedInputsNeitherCrashNorProduceNaN) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  bool with_estimator = false;
  int width = 640, height = 480;
  pnh.param("with_estimator", with_estimator, with_estimator);
  pnh.param("image_width", width, width);
  pnh.param("image_height", height, height);
  std::vector<std::string> nodes = {"/fe/sonar_filter", "/fe/magnetometer", "/pg/pose_graph"};
  if (with_estimator) nodes.push_back("/est/estimator");

  ros::AsyncSpinner spinner(2);
  spinner.start();

  OutputMonitor out;
  out.watch<vims::FilteredSonarRange>(nh, "/fe/sonar/filtered");
  out.watch<vims::MagneticSignature>(nh, "/fe/mag/signature");
  out.watch<sensor_msgs::MagneticField>(nh, "/fe/mag/geomagnetic");
  out.watch<nav_msgs::Path>(nh, "/pg/global/path");
  out.watch<nav_msgs::Odometry>(nh, "/pg/global/odometry");
  out.watch<visualization_msgs::Marker>(nh, "/pg/global/loop_edges");
  out.watch<visualization_msgs::MarkerArray>(nh, "/pg/global/map_markers");
  out.watch<tf2_msgs::TFMessage>(nh, "/tf");
  if (with_estimator) {
    out.watch<nav_msgs::Odometry>(nh, "/est/vio/odometry");
    out.watch<nav_msgs::Odometry>(nh, "/est/vio/imu_odometry");
    out.watch<nav_msgs::Path>(nh, "/est/vio/path");
    out.watch<vims::Keyframe>(nh, "/est/vio/keyframe");
  }

  // Large publisher queues: every message is sent (the subscribers' queues decide what is kept).
  const uint32_t q = 20000;
  auto pub_range = nh.advertise<sensor_msgs::Range>("/fuzz/sonar/range", q);
  auto pub_imu = nh.advertise<sensor_msgs::Imu>("/fuzz/imu0", q);
  auto pub_mag = nh.advertise<sensor_msgs::MagneticField>("/fuzz/mag/raw", q);
  auto pub_keyframe = nh.advertise<vims::Keyframe>("/pg/vio/keyframe", q);
  auto pub_signature = nh.advertise<vims::MagneticSignature>("/pg/mag/signature", q);
  auto pub_geomagnetic = nh.advertise<sensor_msgs::MagneticField>("/pg/mag/geomagnetic", q);
  auto pub_odometry = nh.advertise<nav_msgs::Odometry>("/pg/vio/odometry", q);
  ros::Publisher pub_image, pub_filtered;
  if (with_estimator) {
    pub_image = nh.advertise<sensor_msgs::Image>("/fuzz/cam0/image_raw", 200);
    pub_filtered = nh.advertise<vims::FilteredSonarRange>("/est/sonar/filtered", q);
  }
  std::vector<ros::Publisher*> inputs = {&pub_range,     &pub_imu,         &pub_mag,     &pub_keyframe,
                                         &pub_signature, &pub_geomagnetic, &pub_odometry};
  if (with_estimator) {
    inputs.push_back(&pub_image);
    inputs.push_back(&pub_filtered);
  }
  // The nodes are up (the pose graph loads its vocabularies first) and connected both ways.
  ASSERT_TRUE(waitFor(
      [&] {
        for (ros::Publisher* p : inputs)
          if (p->getNumSubscribers() == 0) return false;
        for (const ros::Subscriber& s : out.subscribers())
          if (s.getNumPublishers() == 0) return false;
        return true;
      },
      60.0))
      << "the nodes did not subscribe / advertise in time";
  for (const std::string& node : nodes) {
    std::string why;
    ASSERT_TRUE(nodeAlive(node, &why)) << node << " before the test: " << why;
  }

  // The hostile stream: message i of every topic, fast (the mag topic at 1000 per unit of i
  // would be too slow, so all topics advance together; the stamps say which rate each mimics).
  std::mt19937 rng(42);
  const ros::WallTime start = ros::WallTime::now();
  for (int i = 0; i < kMessagesPerTopic && ros::ok(); ++i) {
    pub_range.publish(hostileRange(i, rng));
    pub_imu.publish(hostileImu(i, rng));
    pub_mag.publish(hostileMag(i, 1000.0, rng));
    pub_keyframe.publish(hostileKeyframe(i, width, height, rng));
    pub_signature.publish(hostileSignature(i));
    pub_geomagnetic.publish(hostileGeomagnetic(i));
    pub_odometry.publish(hostileOdometry(i));
    if (with_estimator) {
      pub_image.publish(hostileImage(i, width, height, rng));
      pub_filtered.publish(hostileFilteredRange(i, rng));
    }
    // ~2000 messages per topic and second: fast, yet the nodes' queues see most of them.
    if (i % 20 == 19) ros::WallDuration(0.01).sleep();
  }
  std::cout << kMessagesPerTopic << " hostile messages per topic in " << (ros::WallTime::now() - start).toSec()
            << " s\n";
  ros::WallDuration(3.0).sleep();  // the nodes work off their queues

  for (const std::string& node : nodes) {
    std::string why;
    EXPECT_TRUE(nodeAlive(node, &why)) << node << " died during the hostile stream: " << why;
  }

  // Still working: good data after the storm gives good output.
  // Sonar filter: 4 s of steady 3 m ranges; it re-acquires and publishes them.
  for (int k = 0; k < 40; ++k) {
    sensor_msgs::Range m = hostileRange(10, rng);  // case 10: a good range
    m.header.stamp = ros::Time(kRecover + 0.1 * k);
    pub_range.publish(m);
    ros::WallDuration(0.005).sleep();
  }
  EXPECT_TRUE(waitFor([&] { return out.lastStamp("/fe/sonar/filtered") >= kRecover; }, 10.0))
      << "the sonar filter publishes nothing for good ranges after the hostile stream";
  // Magnetometer: 5 s of good 1000 Hz field and 200 Hz IMU: geomagnetic vectors and windows.
  for (int k = 0; k < 5000; ++k) {
    sensor_msgs::MagneticField m = hostileMag(5, 1000.0, rng);  // case 5: a good sample
    m.header.stamp = ros::Time(kRecover + 0.001 * k);
    pub_mag.publish(m);
    if (k % 5 == 0) {
      sensor_msgs::Imu imu = hostileImu(5, rng);  // case 5: a good sample
      imu.header.stamp = ros::Time(kRecover + 0.001 * k);
      pub_imu.publish(imu);
    }
    if (k % 100 == 99) ros::WallDuration(0.02).sleep();  // within the node's 2 s input queue
  }
  EXPECT_TRUE(waitFor([&] { return out.lastStamp("/fe/mag/geomagnetic") >= kRecover; }, 10.0))
      << "the magnetometer node publishes no geomagnetic field for good data after the hostile stream";
  EXPECT_TRUE(waitFor([&] { return out.lastStamp("/fe/mag/signature") >= kRecover; }, 10.0))
      << "the magnetometer node publishes no signatures for good data after the hostile stream";
  // Pose graph: a good odometry message is republished in the map frame.
  nav_msgs::Odometry odometry = hostileOdometry(6);  // case 6: good
  odometry.header.stamp = ros::Time(kRecover);
  pub_odometry.publish(odometry);
  EXPECT_TRUE(waitFor([&] { return out.lastStamp("/pg/global/odometry") >= kRecover; }, 10.0))
      << "the pose graph does not republish good odometry after the hostile stream";

  ros::WallDuration(1.5).sleep();  // a publish period of the pose graph's timer
  for (const std::string& node : nodes) {
    std::string why;
    EXPECT_TRUE(nodeAlive(node, &why)) << node << " is not alive at the end: " << why;
  }
  out.expectAllFinite();
  EXPECT_GT(out.messages("/fe/sonar/filtered"), 0);
  EXPECT_GT(out.messages("/fe/mag/signature"), 0);
  EXPECT_GT(out.messages("/pg/global/odometry"), 0);
  spinner.stop();
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "robustness_test");
  return RUN_ALL_TESTS();
}
