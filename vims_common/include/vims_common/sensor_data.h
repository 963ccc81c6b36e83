#pragma once
/// @file sensor_data.h
/// @brief Plain measurement structs that the ROS-free core libraries consume.
/// ROS messages are converted into these in the node wrappers and in the offline runner
/// (vims_ros/conversions.h), never inside a core library. Times are seconds on the bag clock.

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace vims {

/// One IMU sample in the body frame (FLU).
struct ImuSample {
  double t = 0.0;
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   ///< angular rate [rad/s]
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  ///< specific force [m/s^2] (+g up at rest)
};

/// One single-beam sonar reading: slant range along the beam (sonar +z). A dropout is +inf.
struct SonarRange {
  double t = 0.0;
  double range = 0.0;  ///< [m]
};

/// One pressure-sensor reading (contract version 2): absolute pressure at the port.
struct PressureSample {
  double t = 0.0;
  double pressure_pa = 0.0;  ///< [Pa]
};

/// One magnetometer sample in the mag frame (pre-calibrated, offset-free).
struct MagSample {
  double t = 0.0;
  Eigen::Vector3d field = Eigen::Vector3d::Zero();  ///< [tesla]
};

/// One camera image, converted to 8-bit mono. header.stamp = exposure time.
struct CameraFrame {
  double t = 0.0;
  cv::Mat image;  ///< CV_8UC1
};

}  // namespace vims
