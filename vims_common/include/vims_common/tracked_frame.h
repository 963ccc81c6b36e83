#pragma once
/// @file tracked_frame.h
/// @brief The visual front end's output (vims_tracking's FeatureTracker), as the estimator and
/// the offline runner take it. Here, not in the tracker, so the back end depends on the front
/// end's results and not on the front end.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace vims {

/// What the tracker did with a frame.
enum class FrameStatus {
  kTracked,        ///< features of the previous frame were tracked (some may be new)
  kStarted,        ///< no previous frame to track from (first frame, after reset() or a blank frame): all features new
  kResetOnStamp,   ///< stamp not after the previous frame's: warning, all tracks ended, all features new
  kResetOnGap,     ///< more than max_frame_gap_s since the previous frame: warning, all tracks ended, all features new
  kBlank,          ///< camera blackout (no contrast): all tracks ended, no features
  kRejectedEmpty,  ///< empty image: frame ignored, tracks kept for the next frame
  kRejectedType,   ///< not CV_8UC1: frame ignored, tracks kept
  kRejectedSize,   ///< size differs from the calibration: frame ignored, tracks kept
  kRejectedStamp,  ///< non-finite stamp: frame ignored, tracks kept
};

const char* frameStatusName(FrameStatus status);

/// One feature observed in a frame.
struct TrackedFeature {
  std::uint64_t id = 0;  ///< persistent over the track; never reused by this tracker instance
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();       ///< distorted pixel (as in the image)
  Eigen::Vector2d normalized = Eigen::Vector2d::Zero();  ///< undistorted, on the z = 1 plane
  /// Image motion since the previous frame [px/s] (zero for a new feature), e.g. for the
  /// camera-IMU time offset.
  Eigen::Vector2d pixel_velocity = Eigen::Vector2d::Zero();
  /// The same motion on the normalised plane [1/s], the form the time-offset residual uses.
  Eigen::Vector2d normalized_velocity = Eigen::Vector2d::Zero();
  /// Number of frames the feature has been seen in, this one included (1 = new).
  int track_length = 1;
};

/// Counters and timings of one frame.
struct TrackerStats {
  int tracked = 0;             ///< features continued from the previous frame
  int detected = 0;            ///< new features
  int lost_klt = 0;            ///< KLT did not converge or left the image border
  int rejected_fb = 0;         ///< failed the forward-backward check
  int rejected_ransac = 0;     ///< outliers of the fundamental-matrix RANSAC
  int rejected_undistort = 0;  ///< pixel could not be undistorted (outside the lens model's valid area)
  int dropped_by_mask = 0;     ///< tracked but too close to a longer track
  bool ransac_performed = false;
  double quality_level = 0.0;  ///< relative Shi-Tomasi level the detection had to go down to
  double image_stddev = 0.0;   ///< contrast of the raw frame (grey levels, 4x downsampled)
  double preprocess_ms = 0.0;  ///< validation, CLAHE, pyramid
  double klt_ms = 0.0;         ///< forward and backward KLT
  double ransac_ms = 0.0;      ///< undistortion and RANSAC of the tracked points
  double detect_ms = 0.0;      ///< mask, Shi-Tomasi, undistortion of the new points
  double total_ms = 0.0;
};

/// The front end's output for one frame.
struct TrackedFrame {
  double t = 0.0;  ///< stamp of the image [s, bag clock]
  FrameStatus status = FrameStatus::kStarted;
  std::vector<TrackedFeature> features;
  TrackerStats stats;

  /// False for frames the tracker ignored (rejected input); the estimator should skip them.
  bool accepted() const;
};

}  // namespace vims
