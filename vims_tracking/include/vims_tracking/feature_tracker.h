#pragma once
/// @file feature_tracker.h
/// @brief The visual front end of the VIO: Shi-Tomasi corners tracked by pyramidal KLT between
/// consecutive frames of one mono camera, cleaned by a forward-backward check and an epipolar
/// RANSAC, spread over the image by a minimum-distance mask, and undistorted with the
/// sequence's calibration. ROS-free; one instance per camera; not thread-safe.
///
/// Per frame:
///   1. validate the input (see FrameStatus for the rule applied to each kind of bad input);
///   2. CLAHE (dark, low-contrast water), image pyramid;
///   3. KLT of the previous frame's features, forward-backward check, border check;
///   4. undistortion, fundamental-matrix RANSAC on the undistorted points;
///   5. minimum-distance thinning (long tracks win), then Shi-Tomasi detection with an
///      adaptive quality level in the free regions, up to max_features.

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>  // cv::CLAHE
#include <string>
#include <vector>

#include "vims_common/camera_model.h"
#include "vims_common/log.h"
#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"
#include "vims_common/tracked_frame.h"
#include "vims_tracking/tracker_options.h"
#include "vims_tracking/tracking_stages.h"

namespace vims {

class FeatureTracker {
 public:
  /// Throws std::invalid_argument for an unusable calibration and ConfigError for options out of range.
  FeatureTracker(const CameraCalibration& calibration, const TrackerOptions& options,
                 LoggerPtr logger = Logger::nullLogger());

  /// Tracks the previous frame's features into `frame` and detects new ones.
  TrackedFrame process(const CameraFrame& frame);

  /// Ends all tracks; the next frame starts afresh (ids keep counting up, they are never reused).
  void reset();

  const CameraModel& camera() const { return camera_; }
  const TrackerOptions& options() const { return options_; }
  std::size_t numActiveTracks() const { return tracks_.size(); }

 private:
  struct Track {
    std::uint64_t id = 0;
    cv::Point2f pixel;
    Eigen::Vector2d normalized = Eigen::Vector2d::Zero();
    Eigen::Vector2d pixel_velocity = Eigen::Vector2d::Zero();
    Eigen::Vector2d normalized_velocity = Eigen::Vector2d::Zero();
    int length = 1;
  };

  /// Validates the frame; returns kTracked if usable, otherwise the rejection status.
  FrameStatus checkInput(const CameraFrame& frame) const;
  /// KLT, forward-backward check and RANSAC of tracks_ from previous_pyramid_ into
  /// current_pyramid_; updates tracks_ and stats.
  void trackIntoCurrentFrame(double dt, TrackerStats* stats);
  /// Thins tracks_ by distance and adds new corners of the detection image of `image` (the
  /// frame's raw image) in the free regions.
  void detectNewFeatures(const cv::Mat& image, TrackerStats* stats);
  /// detection_image_ from the raw image (CLAHE or a copy), once per frame.
  void makeDetectionImage(const cv::Mat& image);

  CameraModel camera_;
  TrackerOptions options_;
  LoggerPtr logger_;
  cv::Ptr<cv::CLAHE> clahe_;

  std::vector<Track> tracks_;
  std::vector<cv::Mat> previous_pyramid_;  ///< empty when there is no frame to track from
  // Per-frame images kept between frames only so that their memory is reused (see
  // CornerResponseBuffers); their content never carries over.
  std::vector<cv::Mat> current_pyramid_;
  cv::Mat detection_image_;             ///< CLAHE (or the raw image): corners are detected here
  bool detection_image_ready_ = false;  ///< detection_image_ is the current frame's
  cv::Mat flattened_;                   ///< flattenIllumination: KLT tracks here
  IlluminationBuffers illumination_buffers_;
  cv::Mat occupancy_;
  CornerResponseBuffers corner_buffers_;
  bool has_last_stamp_ = false;
  double last_stamp_ = 0.0;  ///< stamp of the last accepted frame (blank frames included)
  std::uint64_t next_id_ = 0;
};

}  // namespace vims
