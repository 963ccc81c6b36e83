#pragma once
/// @file vio_system.h
/// @brief The odometry as VIMS wires it, for vims_offline and vims_estimator_node alike.
///
/// The feature tracker feeds the sliding-window estimator; IMU samples, filtered sonar ranges and
/// pressure samples go straight to the estimator. Both entry points make these calls in the
/// order the messages arrive and take the outputs after each one, so the odometry they give is
/// the same by construction (scripts/check_online_offline.sh measures it on a replayed bag).

#include <memory>
#include <vector>

#include "vims_common/log.h"
#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"
#include "vims_common/trajectory_io.h"
#include "vims_estimator/vio_estimator.h"
#include "vims_tracking/feature_tracker.h"

namespace vims {

struct SystemConfig;

/// What the odometry produced since the last VioSystem::takeOutputs.
struct VioOutputs {
  /// Frames that carry a finite pose, in order: the rows of vio.tum and the odometry messages.
  /// (Frames still waiting for the IMU, resets and a non-finite state carry none.)
  std::vector<VioFrameResult> poses;
  std::vector<KeyframeData> keyframes;
  /// Back-end wall time [ms] of every frame processed, with or without a pose.
  std::vector<double> backend_ms;
  /// Image stamps of the frames whose state came out non-finite: left out of `poses`, worth a warning.
  std::vector<double> non_finite_stamps;
};

class VioSystem {
 public:
  /// Uses the `tracker` and `estimator` sections of `config`. Throws ConfigError on bad options.
  VioSystem(const SequenceConfig& sequence, const SystemConfig& config, LoggerPtr logger);

  /// The front end: tracks `frame`. Its state depends on the images alone, so it may run on
  /// another thread, ahead of the feed calls, as long as frames come in order.
  TrackedFrame track(const CameraFrame& frame) { return tracker_.process(frame); }

  void feedImu(const ImuSample& sample) { estimator_.feedImu(sample); }
  void feedTracked(const TrackedFrame& tracked, const cv::Mat& image) { estimator_.feedFrame(tracked, image); }
  /// Filtered ranges of the sonar altitude filter (vims_sonar); not accepted ones are ignored.
  void feedSonar(const SonarFilterResult& result) { estimator_.feedSonar(result); }
  void feedPressure(const PressureSample& sample) { estimator_.feedPressure(sample); }

  /// The outputs that became ready since the last call.
  VioOutputs takeOutputs();

  const VioEstimator& estimator() const { return estimator_; }

 private:
  FeatureTracker tracker_;
  VioEstimator estimator_;
};

/// The vio.tum row of a frame: the body pose at the image stamp as recorded (the estimator moves
/// its state from the td-corrected exposure time to the stamp), so the file lives on the bag clock.
void writeVioTumRow(TumWriter* tum, const VioFrameResult& frame);

}  // namespace vims
