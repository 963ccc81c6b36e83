#pragma once
/// @file keyframe_conversions.h
/// @brief Conversions between the pose-graph messages (vims/Keyframe, vims/MagneticSignature)
/// and the core structs (KeyframeData, SignatureWindow), used by vims_pose_graph_node (and by
/// whoever publishes keyframes). Like conversions.h, every conversion validates its input and
/// returns false with a reason for anything a core must not see (NaN, wrong encoding, ...).

#include <geometry_msgs/Pose.h>
#include <vims/Keyframe.h>
#include <vims/MagneticSignature.h>

#include <Eigen/Geometry>
#include <string>

#include "vims_common/keyframe_data.h"
#include "vims_common/magnetic_signature.h"

namespace vims {

/// A pose message as an isometry. Rejects non-finite values and a quaternion whose norm is not
/// 1 within `kMaxQuaternionNormError` (a float-rounded unit quaternion passes and is normalised).
bool toIsometry(const geometry_msgs::Pose& msg, Eigen::Isometry3d* out, std::string* why);
geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& pose);
inline constexpr double kMaxQuaternionNormError = 1e-3;

/// vims/Keyframe -> KeyframeData (t = header.stamp). Rejects a non-finite or non-unit pose and a
/// non-finite feature (point, pixel or normalised coordinates; the reason names the feature id):
/// a keyframe is all or nothing. An empty image (0 x 0) is kept as an empty cv::Mat (the pose
/// graph makes a node without visual submap); any other image goes through toCameraFrame
/// (mono8 kept, bgr8/rgb8/... converted to grey, unsupported encodings and inconsistent sizes
/// rejected).
bool toKeyframeData(const vims::Keyframe& msg, KeyframeData* out, std::string* why);

/// KeyframeData -> vims/Keyframe, stamped at `t` with frame `odom_frame_id`. The image is
/// encoded as mono8 (CV_8UC1) or bgr8 (CV_8UC3); an empty image gives an empty message image.
/// Rejects other image types, a time ros::Time cannot hold (negative, non-finite) and
/// non-finite poses or features.
bool toKeyframeMsg(const KeyframeData& keyframe, const std::string& odom_frame_id, vims::Keyframe* out,
                   std::string* why);

/// vims/MagneticSignature -> SignatureWindow (t = header.stamp, the window centre). The message's
/// `valid` flag is kept. A valid signature with a non-finite amplitude, geomagnetic field, SNR
/// or frequency is rejected; an invalid one carries no measurement, so its non-finite values
/// become 0 and it is kept (the pose graph then still knows the magnetometer is alive).
/// Rejects window_start > window_end. The message has no flags: `flags` is 0.
bool toSignatureWindow(const vims::MagneticSignature& msg, SignatureWindow* out, std::string* why);

}  // namespace vims
