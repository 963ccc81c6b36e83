#include "vims_tracking/tracking_stages.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace vims {

namespace {

// Shi-Tomasi structure tensor: 3x3 averaging block and 3x3 Sobel derivatives, the usual choice
// for KLT features (small blocks localise corners to the pixel the tracker starts from).
constexpr int kCornerBlockSize = 3;
constexpr int kCornerSobelAperture = 3;
// cv::findFundamentalMat(FM_RANSAC) silently switches to LMedS below 15 points, and LMedS on
// near-exact data keeps only its 7-point sample (it rejected n - 7 of n perfect matches in
// tests). With so few tracks a fundamental matrix is also too weakly determined to judge them.
constexpr std::size_t kMinEpipolarCorrespondences = 15;

bool isFree(const cv::Mat& occupancy, const cv::Point2f& pixel) {
  const int x = static_cast<int>(std::lround(pixel.x));
  const int y = static_cast<int>(std::lround(pixel.y));
  if (x < 0 || y < 0 || x >= occupancy.cols || y >= occupancy.rows) return false;
  return occupancy.at<std::uint8_t>(y, x) != 0;
}

void occupy(cv::Mat* occupancy, const cv::Point2f& pixel, double radius) {
  const cv::Point centre(static_cast<int>(std::lround(pixel.x)), static_cast<int>(std::lround(pixel.y)));
  cv::circle(*occupancy, centre, static_cast<int>(std::lround(radius)), cv::Scalar(0), cv::FILLED);
}

}  // namespace

CornerCandidates findCornerCandidates(const cv::Mat& image, int border_px, double min_response,
                                      double min_quality_level, const cv::Mat& free_mask,
                                      CornerResponseBuffers* buffers) {
  if (image.empty() || image.type() != CV_8UC1) {
    throw std::invalid_argument("findCornerCandidates: expects a non-empty CV_8UC1 image");
  }
  if (!free_mask.empty() && (free_mask.type() != CV_8UC1 || free_mask.size() != image.size())) {
    throw std::invalid_argument("findCornerCandidates: free_mask must be CV_8UC1 of the image size");
  }
  CornerCandidates result;
  // The structure tensor needs a pixel of context on each side; keep at least that margin.
  const int border = std::max(border_px, kCornerBlockSize / 2 + 1);
  if (image.cols <= 2 * border || image.rows <= 2 * border) return result;

  CornerResponseBuffers local_buffers;
  CornerResponseBuffers& work = buffers ? *buffers : local_buffers;
  cv::Mat& response = work.response;
  cv::cornerMinEigenVal(image, response, kCornerBlockSize, kCornerSobelAperture);
  const cv::Rect inner(border, border, image.cols - 2 * border, image.rows - 2 * border);
  double strongest = 0.0;
  cv::minMaxLoc(response(inner), nullptr, &strongest);
  result.max_response = static_cast<float>(strongest);
  const double threshold = std::max(min_response, min_quality_level * strongest);
  if (!(strongest > 0.0) || strongest < threshold) return result;

  cv::Mat& local_max = work.local_max;
  cv::dilate(response, local_max, cv::Mat());  // 3x3 maximum filter
  for (int y = inner.y; y < inner.y + inner.height; ++y) {
    const float* r = response.ptr<float>(y);
    const float* m = local_max.ptr<float>(y);
    const std::uint8_t* free = free_mask.empty() ? nullptr : free_mask.ptr<std::uint8_t>(y);
    for (int x = inner.x; x < inner.x + inner.width; ++x) {
      if (r[x] >= threshold && r[x] == m[x] && (!free || free[x])) {
        result.candidates.push_back({cv::Point2f(static_cast<float>(x), static_cast<float>(y)), r[x]});
      }
    }
  }
  return result;
}

CornerSelection selectCorners(CornerCandidates candidates, const CornerSelectionParams& params, cv::Mat* occupancy) {
  CornerSelection selection;
  selection.quality_level_reached = params.quality_level;
  std::vector<CornerCandidate>& pool = candidates.candidates;
  if (params.max_corners <= 0 || pool.empty()) return selection;

  // Strongest first; equal responses in raster order, so the selection is deterministic.
  const auto stronger = [](const CornerCandidate& a, const CornerCandidate& b) {
    if (a.response != b.response) return a.response > b.response;
    if (a.pixel.y != b.pixel.y) return a.pixel.y < b.pixel.y;
    return a.pixel.x < b.pixel.x;
  };
  double level = params.quality_level;
  auto tier_begin = pool.begin();  // candidates before it were visited at a higher level
  while (true) {
    const double threshold = level * candidates.max_response;
    const auto tier_end =
        std::partition(tier_begin, pool.end(), [&](const CornerCandidate& c) { return c.response >= threshold; });
    std::sort(tier_begin, tier_end, stronger);
    for (auto it = tier_begin; it != tier_end; ++it) {
      if (!isFree(*occupancy, it->pixel)) continue;
      selection.corners.push_back(it->pixel);
      selection.quality_level_reached = level;
      occupy(occupancy, it->pixel, params.min_distance_px);
      if (static_cast<int>(selection.corners.size()) >= params.max_corners) return selection;
    }
    tier_begin = tier_end;
    if (tier_begin == pool.end() || level <= params.min_quality_level) break;
    // Too few corners at this level (sparse, low-texture seabed): accept weaker ones.
    level = std::max(level * params.quality_decrease_factor, params.min_quality_level);
    selection.quality_level_reached = level;
  }
  return selection;
}

std::vector<std::size_t> thinByDistanceLongestFirst(const std::vector<cv::Point2f>& pixels,
                                                    const std::vector<int>& track_lengths, double min_distance_px,
                                                    cv::Mat* occupancy) {
  if (pixels.size() != track_lengths.size()) {
    throw std::invalid_argument("thinByDistanceLongestFirst: pixels and track_lengths differ in size");
  }
  std::vector<std::size_t> order(pixels.size());
  std::iota(order.begin(), order.end(), 0);
  // Long tracks carry the most information for the sliding window: they win a conflict.
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return track_lengths[a] > track_lengths[b]; });
  std::vector<std::size_t> kept;
  kept.reserve(pixels.size());
  for (std::size_t i : order) {
    if (!isFree(*occupancy, pixels[i])) continue;
    kept.push_back(i);
    occupy(occupancy, pixels[i], min_distance_px);
  }
  std::sort(kept.begin(), kept.end());
  return kept;
}

EpipolarCheck epipolarRansac(const std::vector<Eigen::Vector2d>& previous_normalized,
                             const std::vector<Eigen::Vector2d>& current_normalized, double focal_px,
                             double threshold_px, double confidence, int max_iterations) {
  if (previous_normalized.size() != current_normalized.size()) {
    throw std::invalid_argument("epipolarRansac: correspondence lists differ in size");
  }
  EpipolarCheck check;
  check.inlier.assign(previous_normalized.size(), 1);
  if (previous_normalized.size() < kMinEpipolarCorrespondences) return check;

  std::vector<cv::Point2f> previous_px(previous_normalized.size());
  std::vector<cv::Point2f> current_px(current_normalized.size());
  for (std::size_t i = 0; i < previous_normalized.size(); ++i) {
    previous_px[i] = cv::Point2f(static_cast<float>(focal_px * previous_normalized[i].x()),
                                 static_cast<float>(focal_px * previous_normalized[i].y()));
    current_px[i] = cv::Point2f(static_cast<float>(focal_px * current_normalized[i].x()),
                                static_cast<float>(focal_px * current_normalized[i].y()));
  }
  std::vector<std::uint8_t> mask;
  cv::Mat fundamental;
  try {
    fundamental = cv::findFundamentalMat(previous_px, current_px, cv::FM_RANSAC, threshold_px, confidence,
                                         max_iterations, mask);
  } catch (const cv::Exception&) {
    return check;  // degenerate input OpenCV refuses (e.g. all points identical): keep all, see below
  }
  // No model (degenerate configuration): keeping everything is safer than dropping all tracks;
  // the forward-backward check has already removed the gross KLT failures.
  if (fundamental.empty() || mask.size() != previous_px.size()) return check;
  check.inlier = std::move(mask);
  check.performed = true;
  return check;
}

}  // namespace vims
