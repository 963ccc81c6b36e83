#include "vims_tracking/feature_tracker.h"

#include <chrono>
#include <cmath>
#include <opencv2/video/tracking.hpp>

#include "vims_common/timing.h"
#include "vims_tracking/tracking_stages.h"

namespace vims {

namespace {

constexpr const char* kComponent = "tracker";

using Clock = std::chrono::steady_clock;

Eigen::Vector2d toEigen(const cv::Point2f& p) { return Eigen::Vector2d(p.x, p.y); }

// Blank-frame contrast is measured on a copy downsampled by this factor (area averaging): pixel
// noise averages out (by ~4x), scene texture, which spans several pixels, mostly survives.
constexpr int kContrastDownsample = 4;

// The illumination low-pass is computed on a copy downsampled by this factor: its sigma (~20 px)
// spans several downsampled pixels, and the blur then costs 1/64 of the full-resolution one.
constexpr int kIlluminationDownsample = 8;

double sceneContrast(const cv::Mat& image) {
  cv::Mat small;
  cv::resize(image, small, cv::Size(), 1.0 / kContrastDownsample, 1.0 / kContrastDownsample, cv::INTER_AREA);
  cv::Scalar mean, stddev;
  cv::meanStdDev(small, mean, stddev);
  return stddev[0];
}

}  // namespace

FeatureTracker::FeatureTracker(const CameraCalibration& calibration, const TrackerOptions& options, LoggerPtr logger)
    : camera_(calibration), options_(options), logger_(logger ? std::move(logger) : Logger::nullLogger()) {
  options_.validate();
  clahe_ = cv::createCLAHE(options_.clahe_clip_limit, cv::Size(options_.clahe_tiles, options_.clahe_tiles));
}

void FeatureTracker::reset() {
  tracks_.clear();
  previous_pyramid_.clear();
  has_last_stamp_ = false;
}

FrameStatus FeatureTracker::checkInput(const CameraFrame& frame) const {
  if (!std::isfinite(frame.t)) return FrameStatus::kRejectedStamp;
  if (frame.image.empty()) return FrameStatus::kRejectedEmpty;
  if (frame.image.type() != CV_8UC1) return FrameStatus::kRejectedType;
  if (frame.image.cols != camera_.width() || frame.image.rows != camera_.height()) return FrameStatus::kRejectedSize;
  return FrameStatus::kTracked;
}

TrackedFrame FeatureTracker::process(const CameraFrame& frame) {
  const Clock::time_point start = Clock::now();
  TrackedFrame out;
  out.t = frame.t;
  TrackerStats& stats = out.stats;

  // ---- 1. input validation: a rejected frame changes nothing, the next good one continues ----
  out.status = checkInput(frame);
  if (out.status != FrameStatus::kTracked) {
    const double warn_t = std::isfinite(frame.t) ? frame.t : last_stamp_;
    std::string why;
    switch (out.status) {
      case FrameStatus::kRejectedStamp:
        why = "non-finite stamp";
        break;
      case FrameStatus::kRejectedEmpty:
        why = "empty image";
        break;
      case FrameStatus::kRejectedType:
        why = VIMS_STR("image type " << cv::typeToString(frame.image.type()) << ", expected CV_8UC1 (mono8)");
        break;
      default:
        why = VIMS_STR("image " << frame.image.cols << "x" << frame.image.rows << ", calibration " << camera_.width()
                                << "x" << camera_.height());
        break;
    }
    logger_->warnThrottled(kComponent, frameStatusName(out.status), warn_t, 5.0,
                           VIMS_STR("frame at t=" << frame.t << " ignored: " << why));
    stats.total_ms = millisecondsSince(start);
    return out;
  }
  double dt = 0.0;
  if (has_last_stamp_ && !(frame.t > last_stamp_)) {
    // Time went backwards (bag loop, restarted driver) or a duplicate stamp: velocities and the
    // estimator's window would be nonsense, so all tracks end and the frame starts afresh.
    logger_->warn(kComponent, VIMS_STR("frame stamp " << frame.t << " is not after the previous " << last_stamp_
                                                      << ": resetting the tracker (all tracks end)"));
    reset();
    out.status = FrameStatus::kResetOnStamp;
  } else if (has_last_stamp_ && frame.t - last_stamp_ > options_.max_frame_gap_s) {
    logger_->warn(kComponent,
                  VIMS_STR("no usable frame for " << frame.t - last_stamp_ << " s (max_frame_gap_s "
                                                  << options_.max_frame_gap_s << "): all tracks end at t=" << frame.t));
    reset();
    out.status = FrameStatus::kResetOnGap;
  } else if (previous_pyramid_.empty()) {
    out.status = FrameStatus::kStarted;
  } else {
    dt = frame.t - last_stamp_;
  }
  has_last_stamp_ = true;
  last_stamp_ = frame.t;

  // ---- 2. blackout check, contrast equalisation, pyramid ----
  stats.image_stddev = sceneContrast(frame.image);
  if (stats.image_stddev <= options_.blank_frame_max_stddev) {
    logger_->warnThrottled(kComponent, "blank", frame.t, 5.0,
                           VIMS_STR("blank frame at t=" << frame.t << " (contrast " << stats.image_stddev
                                                        << " grey levels): all tracks end"));
    tracks_.clear();
    previous_pyramid_.clear();
    out.status = FrameStatus::kBlank;
    stats.total_ms = millisecondsSince(start);
    return out;
  }
  // Corners are detected on the contrast-equalised image: CLAHE's clip limit bounds how much it
  // lifts the noise of dark regions, so the detector's response still reflects how well a corner
  // stands out of the noise. KLT tracks on the flattened image, whose grey levels move with the
  // scene (flattenIllumination). Detecting on the flattened image too picked noise corners in
  // the dark image corners: 2.8x as many tracks started and died on tank30 (docs/frontends.md).
  // With illumination flattening, the detection image is only needed on the frames that detect
  // (detectNewFeatures makes it then); without, KLT tracks on it too.
  detection_image_ready_ = false;
  const cv::Mat* tracking_image = &detection_image_;
  if (options_.illumination_sigma_px <= 0.0) {
    makeDetectionImage(frame.image);
  } else {
    flattenIllumination(frame.image, options_.illumination_sigma_px, kIlluminationDownsample,
                        options_.illumination_target_mean, &flattened_, &illumination_buffers_);
    tracking_image = &flattened_;
  }
  const cv::Size window(options_.klt_window_px, options_.klt_window_px);
  // With the Scharr derivatives stored in the pyramid (each level's image, then its derivatives):
  // calcOpticalFlowPyrLK would otherwise recompute them for its first image on every call, and
  // every frame is that first image twice (backward check now, forward tracking next frame).
  cv::buildOpticalFlowPyramid(*tracking_image, current_pyramid_, window, options_.klt_max_level,
                              /*withDerivatives=*/true);
  stats.preprocess_ms = millisecondsSince(start);

  // ---- 3./4. track the previous features ----
  if (out.status == FrameStatus::kTracked) {
    trackIntoCurrentFrame(dt, &stats);
  }

  // ---- 5. spread and refill ----
  detectNewFeatures(frame.image, &stats);
  // The current pyramid becomes the previous one; the old previous one's memory is reused next frame.
  std::swap(previous_pyramid_, current_pyramid_);

  out.features.reserve(tracks_.size());
  for (const Track& track : tracks_) {
    TrackedFeature f;
    f.id = track.id;
    f.pixel = toEigen(track.pixel);
    f.normalized = track.normalized;
    f.pixel_velocity = track.pixel_velocity;
    f.normalized_velocity = track.normalized_velocity;
    f.track_length = track.length;
    out.features.push_back(f);
  }
  stats.total_ms = millisecondsSince(start);
  return out;
}

void FeatureTracker::trackIntoCurrentFrame(double dt, TrackerStats* stats) {
  if (tracks_.empty()) return;
  const std::vector<cv::Mat>& pyramid = current_pyramid_;
  Clock::time_point stage_start = Clock::now();
  const cv::Size window(options_.klt_window_px, options_.klt_window_px);
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, options_.klt_max_iterations,
                                  options_.klt_epsilon);

  std::vector<cv::Point2f> previous_pixels(tracks_.size());
  for (std::size_t i = 0; i < tracks_.size(); ++i) previous_pixels[i] = tracks_[i].pixel;
  std::vector<cv::Point2f> current_pixels;
  std::vector<std::uint8_t> forward_ok;
  std::vector<float> klt_error;
  cv::calcOpticalFlowPyrLK(previous_pyramid_, pyramid, previous_pixels, current_pixels, forward_ok, klt_error, window,
                           options_.klt_max_level, criteria, 0, options_.klt_min_eigen_threshold);

  // Forward survivors that stayed inside the border go back for the forward-backward check.
  std::vector<std::size_t> candidates;
  for (std::size_t i = 0; i < tracks_.size(); ++i) {
    if (forward_ok[i] && camera_.isInImage(toEigen(current_pixels[i]), options_.border_px)) {
      candidates.push_back(i);
    } else {
      ++stats->lost_klt;
    }
  }
  std::vector<cv::Point2f> forward_pixels(candidates.size());
  std::vector<cv::Point2f> backward_pixels(candidates.size());
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    forward_pixels[k] = current_pixels[candidates[k]];
    backward_pixels[k] = previous_pixels[candidates[k]];  // initial guess: where it came from
  }
  std::vector<std::uint8_t> backward_ok;
  if (!candidates.empty()) {
    cv::calcOpticalFlowPyrLK(pyramid, previous_pyramid_, forward_pixels, backward_pixels, backward_ok, klt_error,
                             window, options_.klt_max_level, criteria, cv::OPTFLOW_USE_INITIAL_FLOW,
                             options_.klt_min_eigen_threshold);
  }
  std::vector<std::size_t> consistent;
  std::vector<Eigen::Vector2d> current_normalized;
  const double max_fb_squared = options_.fb_max_error_px * options_.fb_max_error_px;
  stats->klt_ms = millisecondsSince(stage_start);

  stage_start = Clock::now();
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    const cv::Point2f miss = backward_pixels[k] - previous_pixels[candidates[k]];
    if (!backward_ok[k] || !(miss.dot(miss) <= max_fb_squared)) {
      ++stats->rejected_fb;
      continue;
    }
    const std::optional<Eigen::Vector2d> normalized = camera_.normalizedFromPixel(toEigen(forward_pixels[k]));
    if (!normalized) {
      ++stats->rejected_undistort;
      continue;
    }
    consistent.push_back(candidates[k]);
    current_normalized.push_back(*normalized);
  }

  std::vector<Eigen::Vector2d> previous_normalized(consistent.size());
  for (std::size_t k = 0; k < consistent.size(); ++k) previous_normalized[k] = tracks_[consistent[k]].normalized;
  EpipolarCheck epipolar;
  if (options_.ransac_enabled) {
    epipolar = epipolarRansac(previous_normalized, current_normalized, camera_.meanFocal(),
                              options_.ransac_threshold_px, options_.ransac_confidence, options_.ransac_max_iterations);
  } else {
    epipolar.inlier.assign(consistent.size(), 1);
  }
  stats->ransac_performed = epipolar.performed;

  std::vector<Track> survivors;
  survivors.reserve(consistent.size());
  for (std::size_t k = 0; k < consistent.size(); ++k) {
    if (!epipolar.inlier[k]) {
      ++stats->rejected_ransac;
      continue;
    }
    Track track = tracks_[consistent[k]];
    const cv::Point2f& pixel = current_pixels[consistent[k]];
    track.pixel_velocity = (toEigen(pixel) - toEigen(track.pixel)) / dt;
    track.normalized_velocity = (current_normalized[k] - track.normalized) / dt;
    track.pixel = pixel;
    track.normalized = current_normalized[k];
    ++track.length;
    survivors.push_back(track);
  }
  tracks_ = std::move(survivors);
  stats->ransac_ms = millisecondsSince(stage_start);
}

void FeatureTracker::makeDetectionImage(const cv::Mat& image) {
  if (detection_image_ready_) return;
  if (options_.clahe_enabled) {
    clahe_->apply(image, detection_image_);
  } else {
    image.copyTo(detection_image_);
  }
  detection_image_ready_ = true;
}

void FeatureTracker::detectNewFeatures(const cv::Mat& image, TrackerStats* stats) {
  const Clock::time_point stage_start = Clock::now();
  // Free = 255. Existing tracks claim their neighbourhood first, longest first, so a new
  // corner never crowds out a feature the estimator already has many observations of.
  occupancy_.create(image.size(), CV_8UC1);
  occupancy_.setTo(cv::Scalar(255));
  cv::Mat& occupancy = occupancy_;
  std::vector<cv::Point2f> pixels(tracks_.size());
  std::vector<int> lengths(tracks_.size());
  for (std::size_t i = 0; i < tracks_.size(); ++i) {
    pixels[i] = tracks_[i].pixel;
    lengths[i] = tracks_[i].length;
  }
  const std::vector<std::size_t> kept =
      thinByDistanceLongestFirst(pixels, lengths, options_.min_distance_px, &occupancy);
  stats->dropped_by_mask = static_cast<int>(tracks_.size() - kept.size());
  if (kept.size() != tracks_.size()) {
    std::vector<Track> thinned;
    thinned.reserve(kept.size());
    for (std::size_t i : kept) thinned.push_back(tracks_[i]);
    tracks_ = std::move(thinned);
  }
  // tracks_ never exceeds max_features: every track was detected within the budget and
  // tracking only removes tracks.
  stats->tracked = static_cast<int>(tracks_.size());
  stats->quality_level = options_.quality_level;

  const int wanted = options_.max_features - static_cast<int>(tracks_.size());
  if (wanted > 0 && (wanted >= options_.detect_min_missing || tracks_.empty())) {
    // Only free regions can take a corner: skipping the rest keeps the candidate list (and its
    // sort) short when most of the image is already covered by tracks.
    makeDetectionImage(image);
    CornerCandidates candidates =
        findCornerCandidates(detection_image_, options_.border_px, options_.min_corner_response,
                             options_.min_quality_level, occupancy, &corner_buffers_);
    CornerSelectionParams params;
    params.max_corners = wanted;
    params.min_distance_px = options_.min_distance_px;
    params.quality_level = options_.quality_level;
    params.min_quality_level = options_.min_quality_level;
    params.quality_decrease_factor = options_.quality_decrease_factor;
    const CornerSelection selection = selectCorners(std::move(candidates), params, &occupancy);
    stats->quality_level = selection.quality_level_reached;
    for (const cv::Point2f& corner : selection.corners) {
      const std::optional<Eigen::Vector2d> normalized = camera_.normalizedFromPixel(toEigen(corner));
      if (!normalized) {
        ++stats->rejected_undistort;
        continue;
      }
      Track track;
      track.id = next_id_++;
      track.pixel = corner;
      track.normalized = *normalized;
      tracks_.push_back(track);
      ++stats->detected;
    }
  }
  stats->detect_ms = millisecondsSince(stage_start);
}

}  // namespace vims
