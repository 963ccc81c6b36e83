#pragma once
/// @file sequence_config.h
/// @brief The sensor configuration of one sequence (`<seq>.yaml`), as defined by the sensor
/// data contract (docs/sensor-contract.md). Every calibration VIMS uses comes from here.

#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "vims_common/config_reader.h"

namespace vims {

struct TopicNames {
  std::string image = "/cam0/image_raw";
  std::string imu = "/imu0";
  std::string sonar = "/sonar/range";
  std::string mag = "/mag/raw";
  /// Read only when the sequence has a `pressure` section (contract version 2).
  std::string pressure = "/pressure";
};

/// The lens distortion of the contract's pinhole camera (`camera.distortion_model`, version 2).
enum class DistortionModel {
  kRadtan,       ///< radial-tangential [k1, k2, p1, p2] (OpenCV's 4-parameter model); the default
  kEquidistant,  ///< fisheye, Kannala-Brandt [k1, k2, k3, k4] (OpenCV's fisheye module)
};
/// "radtan" / "equidistant" (the YAML spelling).
const char* distortionModelName(DistortionModel model);

/// Pinhole camera with radtan or equidistant distortion (vims_common/camera_model.h).
struct CameraCalibration {
  std::string model = "pinhole";
  int width = 640;
  int height = 480;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  DistortionModel distortion_model = DistortionModel::kRadtan;
  std::array<double, 4> distortion{{0, 0, 0, 0}};           ///< radtan: k1, k2, p1, p2; equidistant: k1..k4
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();  ///< camera optical frame in body
  double rate_hz = 10.0;
};

struct ImuCalibration {
  double rate_hz = 200.0;
  double gyro_noise_density = 0.0;   ///< rad/s/sqrt(Hz)
  double gyro_random_walk = 0.0;     ///< rad/s^2/sqrt(Hz)
  double accel_noise_density = 0.0;  ///< m/s^2/sqrt(Hz)
  double accel_random_walk = 0.0;    ///< m/s^3/sqrt(Hz)
  double gravity = 9.81;             ///< m/s^2
};

struct SonarCalibration {
  Eigen::Isometry3d T_b_s = Eigen::Isometry3d::Identity();  ///< beam along the sonar +z axis
  double rate_hz = 10.0;
  double range_noise_std = 0.0;  ///< m
  double min_range = 0.1;        ///< m
  double max_range = 50.0;       ///< m
};

struct MagnetometerCalibration {
  Eigen::Isometry3d T_b_m = Eigen::Isometry3d::Identity();
  double rate_hz = 1000.0;
  double noise_std = 0.0;  ///< tesla, per axis and sample
  /// Frequency of the seabed coil's alternating field [Hz]; 0 when the sequence leaves it open
  /// (contract v2: `null` or no key), and the magnetometer front end finds it from the data.
  double coil_frequency_hz = 11.0;
  /// The coils the sequence lists after the first (contract v2: a list). The front end extracts
  /// signatures at coil_frequency_hz; places near these coils are recognised visually.
  std::vector<double> other_coil_frequencies_hz;
  double declination_deg = 0.0;  ///< magnetic declination at the site, east positive

  bool coilFrequencyKnown() const { return coil_frequency_hz > 0.0; }
};

/// Pressure (depth) sensor, optional (contract version 2): absolute pressure at the port.
struct PressureCalibration {
  Eigen::Isometry3d T_b_p = Eigen::Isometry3d::Identity();  ///< only the port's position matters
  double rate_hz = 10.0;
  double noise_std_pa = 0.0;
  double atmospheric_pa = 101325.0;
  double water_density = 1025.0;  ///< kg/m^3

  /// Depth of the port below the surface [m] for an absolute pressure [Pa]:
  /// (p - atmospheric_pa) / (water_density * gravity).
  double depthOf(double pressure_pa, double gravity) const;
  /// Standard deviation of that depth [m] for the sensor's noise_std_pa.
  double depthStd(double gravity) const;
};

struct SequenceConfig {
  TopicNames topics;
  CameraCalibration camera;
  ImuCalibration imu;
  SonarCalibration sonar;
  MagnetometerCalibration magnetometer;
  /// Present when the sequence YAML has a `pressure` section (its bag then has the topic).
  std::optional<PressureCalibration> pressure;

  /// Reads and validates a sequence YAML. Throws ConfigError naming the bad key.
  /// Keys the contract does not define are returned in `unknown_keys` (if given): another
  /// recorder may add its own, so they are worth a warning, not a failure.
  static SequenceConfig load(const std::string& path, std::vector<std::string>* unknown_keys = nullptr);
  static SequenceConfig fromReader(const ConfigReader& root, std::vector<std::string>* unknown_keys = nullptr);

  /// Writes the contract's YAML (loadable by `rosparam load`). Throws std::runtime_error on I/O failure.
  void save(const std::string& path) const;
  std::string toYaml() const;
};

}  // namespace vims
