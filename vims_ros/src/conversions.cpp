#include "vims_ros/conversions.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace vims {
namespace {
bool finite3(double x, double y, double z) { return std::isfinite(x) && std::isfinite(y) && std::isfinite(z); }
bool fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

bool checkSize(int width, int height, int expected_width, int expected_height, std::string* why) {
  if (expected_width > 0 && expected_height > 0 && (width != expected_width || height != expected_height)) {
    return fail(why, "image is " + std::to_string(width) + "x" + std::to_string(height) + ", calibration says " +
                         std::to_string(expected_width) + "x" + std::to_string(expected_height));
  }
  return true;
}

/// "jpeg", "png" or "" (unsupported), from a CompressedImage format string.
std::string compressionOf(std::string format) {
  std::transform(format.begin(), format.end(), format.begin(), [](unsigned char c) { return std::tolower(c); });
  if (format.find("jpeg") != std::string::npos || format.find("jpg") != std::string::npos) return "jpeg";
  if (format.find("png") != std::string::npos) return "png";
  return "";
}
}  // namespace

bool toImuSample(const sensor_msgs::Imu& msg, ImuSample* out, std::string* why) {
  const auto& w = msg.angular_velocity;
  const auto& a = msg.linear_acceleration;
  if (!finite3(w.x, w.y, w.z)) return fail(why, "non-finite angular_velocity");
  if (!finite3(a.x, a.y, a.z)) return fail(why, "non-finite linear_acceleration");
  out->t = toSec(msg.header.stamp);
  out->gyro = Eigen::Vector3d(w.x, w.y, w.z);
  out->accel = Eigen::Vector3d(a.x, a.y, a.z);
  return true;
}

bool toSonarRange(const sensor_msgs::Range& msg, SonarRange* out, std::string* why) {
  if (std::isnan(msg.range)) return fail(why, "range is NaN");
  out->t = toSec(msg.header.stamp);
  out->range = static_cast<double>(msg.range);
  return true;
}

bool toPressureSample(const sensor_msgs::FluidPressure& msg, PressureSample* out, std::string* why) {
  if (!std::isfinite(msg.fluid_pressure)) return fail(why, "fluid_pressure is not finite");
  if (!(msg.fluid_pressure > 0.0)) return fail(why, "fluid_pressure is not positive (absolute pascal expected)");
  out->t = toSec(msg.header.stamp);
  out->pressure_pa = msg.fluid_pressure;
  return true;
}

bool toMagSample(const sensor_msgs::MagneticField& msg, MagSample* out, std::string* why) {
  const auto& b = msg.magnetic_field;
  if (!finite3(b.x, b.y, b.z)) return fail(why, "non-finite magnetic_field");
  out->t = toSec(msg.header.stamp);
  out->field = Eigen::Vector3d(b.x, b.y, b.z);
  return true;
}

bool toCameraFrame(const sensor_msgs::Image& msg, int expected_width, int expected_height, CameraFrame* out,
                   std::string* why) {
  if (msg.width == 0 || msg.height == 0) return fail(why, "empty image");
  if (!checkSize(static_cast<int>(msg.width), static_cast<int>(msg.height), expected_width, expected_height, why)) {
    return false;
  }
  int cv_type = -1;
  int channels = 0;
  int bytes_per_channel = 1;
  const std::string& enc = msg.encoding;
  if (enc == "mono8" || enc == "8UC1") {
    cv_type = CV_8UC1, channels = 1;
  } else if (enc == "mono16" || enc == "16UC1") {
    cv_type = CV_16UC1, channels = 1, bytes_per_channel = 2;
  } else if (enc == "bgr8" || enc == "rgb8") {
    cv_type = CV_8UC3, channels = 3;
  } else if (enc == "bgra8" || enc == "rgba8") {
    cv_type = CV_8UC4, channels = 4;
  } else {
    return fail(why, "unsupported image encoding '" + enc + "' (expected mono8, mono16, bgr8 or rgb8)");
  }
  const std::size_t row_bytes = static_cast<std::size_t>(msg.width) * channels * bytes_per_channel;
  if (msg.step < row_bytes) return fail(why, "image step " + std::to_string(msg.step) + " is shorter than a row");
  if (msg.data.size() < static_cast<std::size_t>(msg.step) * msg.height) {
    return fail(why, "image data holds " + std::to_string(msg.data.size()) + " bytes, header says " +
                         std::to_string(static_cast<std::size_t>(msg.step) * msg.height));
  }
  if (bytes_per_channel == 2 && msg.is_bigendian) return fail(why, "big-endian mono16 images are not supported");
  // The view aliases the message buffer; every branch below produces an owned copy.
  const cv::Mat view(static_cast<int>(msg.height), static_cast<int>(msg.width), cv_type,
                     const_cast<uint8_t*>(msg.data.data()), msg.step);
  cv::Mat mono;
  if (enc == "mono8" || enc == "8UC1") {
    mono = view.clone();
  } else if (cv_type == CV_16UC1) {
    view.convertTo(mono, CV_8UC1, 1.0 / 256.0);
  } else if (enc == "bgr8") {
    cv::cvtColor(view, mono, cv::COLOR_BGR2GRAY);
  } else if (enc == "rgb8") {
    cv::cvtColor(view, mono, cv::COLOR_RGB2GRAY);
  } else if (enc == "bgra8") {
    cv::cvtColor(view, mono, cv::COLOR_BGRA2GRAY);
  } else {
    cv::cvtColor(view, mono, cv::COLOR_RGBA2GRAY);
  }
  out->t = toSec(msg.header.stamp);
  out->image = mono;
  return true;
}

bool toCameraFrame(const sensor_msgs::CompressedImage& msg, int expected_width, int expected_height, CameraFrame* out,
                   std::string* why) {
  if (compressionOf(msg.format).empty()) {
    return fail(why, "unsupported compressed image format '" + msg.format + "' (expected jpeg or png)");
  }
  if (msg.data.empty()) return fail(why, "empty compressed image");
  const cv::Mat encoded(1, static_cast<int>(msg.data.size()), CV_8UC1, const_cast<uint8_t*>(msg.data.data()));
  cv::Mat decoded;
  try {
    decoded = cv::imdecode(encoded, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    return fail(why, std::string("compressed image does not decode: ") + e.what());
  }
  if (decoded.empty()) return fail(why, "compressed image (" + msg.format + ") does not decode");
  if (!checkSize(decoded.cols, decoded.rows, expected_width, expected_height, why)) return false;
  cv::Mat mono;
  if (decoded.depth() == CV_16U) decoded.convertTo(decoded, CV_8U, 1.0 / 256.0);
  if (decoded.depth() != CV_8U) return fail(why, "compressed image has an unsupported pixel depth");
  switch (decoded.channels()) {
    case 1:
      mono = decoded;
      break;  // imdecode's buffer is owned
    case 3:
      cv::cvtColor(decoded, mono, cv::COLOR_BGR2GRAY);
      break;
    case 4:
      cv::cvtColor(decoded, mono, cv::COLOR_BGRA2GRAY);
      break;
    default:
      return fail(why, "compressed image has " + std::to_string(decoded.channels()) + " channels");
  }
  out->t = toSec(msg.header.stamp);
  out->image = mono;
  return true;
}

}  // namespace vims
