#include "vims_tracking/feature_drawing.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>

namespace vims {

namespace {

// Used when the image cannot be drawn on: the contract camera's size.
const cv::Size kFallbackSize(640, 480);

}  // namespace

cv::Scalar trackLengthColour(int track_length, int saturation_track_length) {
  const int span = std::max(1, saturation_track_length - 1);
  const double ratio = std::clamp(static_cast<double>(track_length - 1) / span, 0.0, 1.0);
  return cv::Scalar(255.0 * (1.0 - ratio), 0.0, 255.0 * ratio);  // BGR: blue -> red
}

cv::Mat drawTrackedFeatures(const cv::Mat& image, const TrackedFrame& frame, const FeatureDrawingOptions& options) {
  cv::Mat canvas;
  if (!image.empty() && image.type() == CV_8UC1) {
    cv::cvtColor(image, canvas, cv::COLOR_GRAY2BGR);
  } else if (!image.empty() && image.type() == CV_8UC3) {
    canvas = image.clone();
  } else {
    canvas = cv::Mat(image.empty() ? kFallbackSize : image.size(), CV_8UC3, cv::Scalar::all(0));
  }
  for (const TrackedFeature& feature : frame.features) {
    if (!feature.pixel.allFinite()) continue;
    const cv::Scalar colour = trackLengthColour(feature.track_length, options.saturation_track_length);
    const cv::Point2d centre(feature.pixel.x(), feature.pixel.y());
    cv::circle(canvas, centre, options.circle_radius_px, colour, 2, cv::LINE_AA);
    if (feature.track_length > 1 && feature.pixel_velocity.allFinite()) {
      const cv::Point2d previous(centre.x - feature.pixel_velocity.x() * options.motion_line_seconds,
                                 centre.y - feature.pixel_velocity.y() * options.motion_line_seconds);
      cv::line(canvas, previous, centre, colour, 1, cv::LINE_AA);
    }
  }
  if (options.draw_count) {
    const std::string text = std::to_string(frame.features.size()) + " features";
    cv::putText(canvas, text, cv::Point(8, 20), cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 255, 0), 1, cv::LINE_AA);
  }
  return canvas;
}

}  // namespace vims
