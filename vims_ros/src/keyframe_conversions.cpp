#include "vims_ros/keyframe_conversions.h"

#include <cmath>
#include <cstring>

#include "vims_ros/conversions.h"

namespace vims {
namespace {

bool fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

Eigen::Vector3d toEigen(const geometry_msgs::Vector3& v) { return Eigen::Vector3d(v.x, v.y, v.z); }

/// The reason a feature cannot go to the pose graph, or "" when it can.
std::string featureProblem(const KeyframeLandmark& feature) {
  if (!feature.p_odom.allFinite()) return "feature " + std::to_string(feature.id) + " has a non-finite point";
  if (!feature.pixel.allFinite()) return "feature " + std::to_string(feature.id) + " has a non-finite pixel";
  if (!feature.normalized.allFinite()) {
    return "feature " + std::to_string(feature.id) + " has non-finite normalised coordinates";
  }
  return "";
}

/// ros::Time holds unsigned 32-bit seconds.
bool representableAsRosTime(double t) { return std::isfinite(t) && t >= 0.0 && t < 4294967295.0; }

}  // namespace

bool toIsometry(const geometry_msgs::Pose& msg, Eigen::Isometry3d* out, std::string* why) {
  const Eigen::Vector3d p(msg.position.x, msg.position.y, msg.position.z);
  if (!p.allFinite()) return fail(why, "non-finite position");
  Eigen::Quaterniond q(msg.orientation.w, msg.orientation.x, msg.orientation.y, msg.orientation.z);
  if (!q.coeffs().allFinite()) return fail(why, "non-finite orientation");
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > kMaxQuaternionNormError) {
    return fail(why, "orientation is not a unit quaternion (norm " + std::to_string(norm) + ")");
  }
  q.normalize();
  out->setIdentity();
  out->linear() = q.toRotationMatrix();
  out->translation() = p;
  return true;
}

geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.rotation());
  geometry_msgs::Pose out;
  out.position.x = pose.translation().x();
  out.position.y = pose.translation().y();
  out.position.z = pose.translation().z();
  out.orientation.w = q.w();
  out.orientation.x = q.x();
  out.orientation.y = q.y();
  out.orientation.z = q.z();
  return out;
}

bool toKeyframeData(const vims::Keyframe& msg, KeyframeData* out, std::string* why) {
  Eigen::Isometry3d T_odom_b;
  std::string pose_problem;
  if (!toIsometry(msg.pose, &T_odom_b, &pose_problem)) return fail(why, "keyframe pose: " + pose_problem);

  KeyframeData keyframe;
  keyframe.t = toSec(msg.header.stamp);
  keyframe.session = msg.session;
  keyframe.T_odom_b = T_odom_b;
  if (msg.has_port_depth) {
    if (!std::isfinite(msg.port_depth)) return fail(why, "keyframe port depth is not finite");
    keyframe.port_depth = msg.port_depth;
  }
  if (msg.has_T_b_c) {
    Eigen::Isometry3d T_b_c;
    std::string extrinsic_problem;
    if (!toIsometry(msg.T_b_c, &T_b_c, &extrinsic_problem))
      return fail(why, "keyframe camera extrinsic: " + extrinsic_problem);
    keyframe.T_b_c = T_b_c;
  }
  keyframe.features.reserve(msg.features.size());
  for (const vims::KeyframeFeature& f : msg.features) {
    KeyframeLandmark feature;
    feature.id = f.id;
    feature.p_odom = Eigen::Vector3d(f.p_odom.x, f.p_odom.y, f.p_odom.z);
    feature.pixel = Eigen::Vector2d(f.u, f.v);
    feature.normalized = Eigen::Vector2d(f.x_norm, f.y_norm);
    const std::string problem = featureProblem(feature);
    if (!problem.empty()) return fail(why, problem);
    keyframe.features.push_back(feature);
  }

  if (msg.image.width != 0 || msg.image.height != 0) {
    CameraFrame frame;
    std::string image_problem;
    if (!toCameraFrame(msg.image, 0, 0, &frame, &image_problem)) return fail(why, "keyframe image: " + image_problem);
    keyframe.image = frame.image;
  }
  *out = std::move(keyframe);
  return true;
}

bool toKeyframeMsg(const KeyframeData& keyframe, const std::string& odom_frame_id, vims::Keyframe* out,
                   std::string* why) {
  if (!representableAsRosTime(keyframe.t)) {
    return fail(why, "keyframe time " + std::to_string(keyframe.t) + " is not a valid ROS time");
  }
  if (!keyframe.T_odom_b.matrix().allFinite()) return fail(why, "keyframe pose is not finite");
  for (const KeyframeLandmark& feature : keyframe.features) {
    const std::string problem = featureProblem(feature);
    if (!problem.empty()) return fail(why, problem);
  }
  std::string encoding;
  if (!keyframe.image.empty()) {
    if (keyframe.image.type() == CV_8UC1) {
      encoding = "mono8";
    } else if (keyframe.image.type() == CV_8UC3) {
      encoding = "bgr8";
    } else {
      return fail(why, "keyframe image type " + std::to_string(keyframe.image.type()) +
                           " is neither CV_8UC1 (mono8) nor CV_8UC3 (bgr8)");
    }
  }

  vims::Keyframe msg;
  msg.header.stamp = ros::Time(keyframe.t);
  msg.header.frame_id = odom_frame_id;
  msg.session = keyframe.session;
  msg.pose = toPoseMsg(keyframe.T_odom_b);
  if (keyframe.port_depth && !std::isfinite(*keyframe.port_depth))
    return fail(why, "keyframe port depth is not finite");
  msg.has_port_depth = keyframe.port_depth.has_value();
  msg.port_depth = keyframe.port_depth.value_or(0.0);
  if (keyframe.T_b_c && !keyframe.T_b_c->matrix().allFinite())
    return fail(why, "keyframe camera extrinsic is not finite");
  msg.has_T_b_c = keyframe.T_b_c.has_value();
  if (keyframe.T_b_c) msg.T_b_c = toPoseMsg(*keyframe.T_b_c);
  msg.features.reserve(keyframe.features.size());
  for (const KeyframeLandmark& feature : keyframe.features) {
    vims::KeyframeFeature f;
    f.id = feature.id;
    f.p_odom.x = feature.p_odom.x();
    f.p_odom.y = feature.p_odom.y();
    f.p_odom.z = feature.p_odom.z();
    f.u = static_cast<float>(feature.pixel.x());
    f.v = static_cast<float>(feature.pixel.y());
    f.x_norm = static_cast<float>(feature.normalized.x());
    f.y_norm = static_cast<float>(feature.normalized.y());
    msg.features.push_back(f);
  }
  if (!keyframe.image.empty()) {
    const cv::Mat& image = keyframe.image;
    const std::size_t row_bytes = static_cast<std::size_t>(image.cols) * image.elemSize();
    msg.image.header = msg.header;
    msg.image.width = static_cast<uint32_t>(image.cols);
    msg.image.height = static_cast<uint32_t>(image.rows);
    msg.image.encoding = encoding;
    msg.image.is_bigendian = 0;
    msg.image.step = static_cast<uint32_t>(row_bytes);
    msg.image.data.resize(row_bytes * static_cast<std::size_t>(image.rows));
    for (int row = 0; row < image.rows; ++row) {  // rows may be padded (ROI views)
      std::memcpy(msg.image.data.data() + row_bytes * static_cast<std::size_t>(row), image.ptr(row), row_bytes);
    }
  }
  *out = std::move(msg);
  return true;
}

bool toSignatureWindow(const vims::MagneticSignature& msg, SignatureWindow* out, std::string* why) {
  if (msg.window_start > msg.window_end) return fail(why, "signature window_start is after window_end");
  SignatureWindow window;
  window.t = toSec(msg.header.stamp);
  window.t_start = toSec(msg.window_start);
  window.t_end = toSec(msg.window_end);
  window.coil = msg.coil;
  window.frequency_hz = msg.frequency_hz;
  window.amplitude_enu = toEigen(msg.amplitude_enu);
  window.geomagnetic_body = toEigen(msg.geomagnetic_body);
  window.snr = msg.snr;
  window.valid = msg.valid;
  window.flags = 0;
  if (window.valid) {
    if (!window.amplitude_enu.allFinite()) return fail(why, "valid signature with a non-finite amplitude_enu");
    if (!window.geomagnetic_body.allFinite()) return fail(why, "valid signature with a non-finite geomagnetic_body");
    if (!std::isfinite(window.snr)) return fail(why, "valid signature with a non-finite snr");
    if (!std::isfinite(window.frequency_hz)) return fail(why, "valid signature with a non-finite frequency_hz");
  } else {
    // An invalid window carries no measurement; keep it (magnetometer alive) without NaN.
    if (!window.amplitude_enu.allFinite()) window.amplitude_enu.setZero();
    if (!window.geomagnetic_body.allFinite()) window.geomagnetic_body.setZero();
    if (!std::isfinite(window.snr)) window.snr = 0.0;
    if (!std::isfinite(window.frequency_hz)) window.frequency_hz = 0.0;
  }
  *out = window;
  return true;
}

}  // namespace vims
