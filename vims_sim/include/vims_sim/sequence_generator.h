#pragma once
/// @file sequence_generator.h
/// @brief Generates a whole sequence: writes `<seq>.yaml`, `<seq>_truth.yaml` and
/// `<seq>_gt.tum`, and streams every bag message, in time order, to a SimSink (the vims_sim
/// executable's sink writes the rosbag; tests can collect messages directly).
///
/// Clock: every stream is a fixed grid of integer nanoseconds from the start time, so rates
/// are exact and stamps strictly increasing: IMU and ground-truth TUM every 5 ms, magnetometer
/// every 1 ms, ground-truth pose messages every 20 ms, camera exposures every 100 ms (stamp =
/// exposure + camera delay), sonar pings every 100 ms offset by 50 ms, pressure samples (if any)
/// every 1 / rate offset by a quarter period (25 ms at 10 Hz). Samples with true time in
/// [0, duration) are produced; dropout spans remove (or black out) some of them.
///
/// Images are rendered by worker threads a bounded number of frames ahead of the writer, so
/// memory stays bounded and the output does not depend on the number of threads.

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <string>

#include "vims_sim/sensor_models.h"
#include "vims_sim/sim_setup.h"

namespace vims {
namespace sim {

/// Receives the bag messages in non-decreasing stamp order (absolute bag-clock nanoseconds).
class SimSink {
 public:
  virtual ~SimSink() = default;
  virtual void imu(int64_t stamp_ns, const ImuMeasurement& measurement) = 0;
  virtual void image(int64_t stamp_ns, const cv::Mat& mono8) = 0;
  virtual void sonar(int64_t stamp_ns, double range) = 0;
  virtual void magnetometer(int64_t stamp_ns, const Eigen::Vector3d& field_m) = 0;
  virtual void groundTruth(int64_t stamp_ns, const Eigen::Isometry3d& T_w_b) = 0;
  /// Absolute pressure at the port [Pa]; only called when the sequence has a pressure sensor.
  virtual void pressure(int64_t stamp_ns, double pressure_pa) = 0;
};

struct GenerationStats {
  double wall_seconds = 0.0;
  double realtime_factor = 0.0;  ///< simulated seconds per wall-clock second
  int64_t imu_messages = 0, image_messages = 0, sonar_messages = 0, mag_messages = 0, pose_messages = 0;
  int64_t pressure_messages = 0;
  int64_t blackout_frames = 0;
  int corner_frames = 0;        ///< frames on which corners were counted (every 5th lit frame)
  double median_corners = 0.0;  ///< Shi-Tomasi (300, 0.01, 15) per frame, median
  int min_corners = 0;
  size_t tiles_generated = 0;
};

/// Called from the writing thread about every 2 % of the sequence.
using ProgressCallback = std::function<void(double sim_time, double duration, double wall_seconds)>;

/// Nanosecond stamp of a time in seconds (rounded).
int64_t secondsToNanoseconds(double seconds);

/// Generates the sequence of `setup` into setup.options.out_dir (created if needed).
/// Throws std::runtime_error on I/O errors.
GenerationStats generateSequence(const SimSetup& setup, SimSink& sink, const ProgressCallback& progress = {});

}  // namespace sim
}  // namespace vims
