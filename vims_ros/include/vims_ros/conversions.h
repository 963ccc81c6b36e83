#pragma once
/// @file conversions.h
/// @brief ROS message -> core measurement struct conversions, shared by every node and by the
/// offline runner so both see exactly the same data. Each conversion validates its input and
/// returns false with a reason for anything a core must not see (NaN, wrong encoding, ...).

#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/FluidPressure.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/Range.h>

#include <string>

#include "vims_common/sensor_data.h"

namespace vims {

inline double toSec(const ros::Time& t) { return t.toSec(); }

/// Rejects non-finite angular rate or specific force.
bool toImuSample(const sensor_msgs::Imu& msg, ImuSample* out, std::string* why);

/// Keeps +inf (REP 117: no return) and out-of-range values for the sonar filter to judge as
/// dropouts; rejects NaN and a non-finite stamp.
bool toSonarRange(const sensor_msgs::Range& msg, SonarRange* out, std::string* why);

/// Rejects a non-finite or non-positive absolute pressure (pascal, contract version 2).
bool toPressureSample(const sensor_msgs::FluidPressure& msg, PressureSample* out, std::string* why);

/// Rejects non-finite field components.
bool toMagSample(const sensor_msgs::MagneticField& msg, MagSample* out, std::string* why);

/// Converts mono8, mono16, bgr8, rgb8, bgra8 and rgba8 to an 8-bit mono image (copied, so the
/// core owns its data). Rejects other encodings, empty images, inconsistent step/data sizes,
/// and a size other than expected_width x expected_height (when those are > 0).
bool toCameraFrame(const sensor_msgs::Image& msg, int expected_width, int expected_height, CameraFrame* out,
                   std::string* why);

/// A compressed image (sensor_msgs/CompressedImage, contract version 2): `format` names jpeg or png
/// (as "jpeg", "png" or image_transport's "bgr8; jpeg compressed bgr8"). Decoded, then made mono
/// exactly as the raw encodings are (colour: BGR to grey; 16-bit png: the upper 8 bits). Rejects
/// other formats, data that does not decode, and a size other than expected (when > 0).
bool toCameraFrame(const sensor_msgs::CompressedImage& msg, int expected_width, int expected_height, CameraFrame* out,
                   std::string* why);

/// The image message types the contract allows on the camera topic.
inline constexpr const char* kRawImageType = "sensor_msgs/Image";
inline constexpr const char* kCompressedImageType = "sensor_msgs/CompressedImage";

}  // namespace vims
