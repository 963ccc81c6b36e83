#pragma once
/// @file feature_drawing.h
/// @brief Debug image of the tracked features (for rviz / image_view): each feature is a
/// circle coloured by its track length, from blue (new) to red (long), with a line along its
/// image motion since the previous frame.

#include <opencv2/core.hpp>

#include "vims_tracking/feature_tracker.h"

namespace vims {

struct FeatureDrawingOptions {
  /// Track length drawn fully red; longer tracks stay red.
  int saturation_track_length = 20;
  int circle_radius_px = 3;
  /// Length of the motion line: pixel velocity times this [s] (0.1 s = one frame at 10 Hz).
  double motion_line_seconds = 0.1;
  /// Writes "N features" in the top-left corner.
  bool draw_count = true;
};

/// BGR colour of a track of the given length (1 = new = blue, >= saturation = red).
cv::Scalar trackLengthColour(int track_length, int saturation_track_length);

/// Returns a CV_8UC3 copy of `image` (CV_8UC1 or CV_8UC3) with the features drawn on it.
/// An empty or unsupported image gives a black image of the feature frame's extent (never throws
/// on bad input, so a debug publisher cannot take the node down).
cv::Mat drawTrackedFeatures(const cv::Mat& image, const TrackedFrame& frame,
                            const FeatureDrawingOptions& options = FeatureDrawingOptions());

}  // namespace vims
