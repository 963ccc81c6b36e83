#include "vims_tracking/tracking_stages.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace vims {

namespace {

// Shi-Tomasi structure tensor: 3x3 summing block and 3x3 Sobel derivatives, the usual choice
// for KLT features (small blocks localise corners to the pixel the tracker starts from).
// OpenCV's cornerMinEigenVal scales the 8-bit Sobel gradients by 1 / (2^(aperture - 1) * block *
// 255) = 1/3060; the response is on that scale (min_corner_response is given on it).
constexpr double kGradientScale = 1.0 / (4.0 * 3.0 * 255.0);
// Context the response needs around a pixel: one for the block, one for the gradient.
constexpr int kResponseContextPx = 2;
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

/// True when `r[x]` is the maximum of its 3x3 neighbourhood (the rows above and below given).
bool isLocalMaximum(const float* above, const float* r, const float* below, int x) {
  const float v = r[x];
  return v >= above[x - 1] && v >= above[x] && v >= above[x + 1] && v >= r[x - 1] && v >= r[x + 1] &&
         v >= below[x - 1] && v >= below[x] && v >= below[x + 1];
}

/// Products of the 3x3 Sobel gradients (dx^2, dx dy, dy^2) at `w` pixels of a row, from the rows
/// above, at and below it (each pointing at the first pixel; one more pixel is read on either
/// side). __restrict: the 8-bit rows could alias the products as far as the compiler knows,
/// which kept the loop from being vectorised.
void gradientProductRow(const std::uint8_t* __restrict up, const std::uint8_t* __restrict mid,
                        const std::uint8_t* __restrict down, int w, std::int32_t* __restrict xx,
                        std::int32_t* __restrict xy, std::int32_t* __restrict yy) {
  for (int i = 0; i < w; ++i) {
    // Sobel 3x3: [-1 0 1] x [1 2 1]^T and its transpose.
    const int dx = (up[i + 1] - up[i - 1]) + 2 * (mid[i + 1] - mid[i - 1]) + (down[i + 1] - down[i - 1]);
    const int dy = (down[i - 1] - up[i - 1]) + 2 * (down[i] - up[i]) + (down[i + 1] - up[i + 1]);
    xx[i] = dx * dx;
    xy[i] = dx * dy;
    yy[i] = dy * dy;
  }
}

}  // namespace

void shiTomasiResponse(const cv::Mat& image, const cv::Rect& roi, cv::Mat* response, CornerResponseBuffers* buffers) {
  if (image.empty() || image.type() != CV_8UC1) {
    throw std::invalid_argument("shiTomasiResponse: expects a non-empty CV_8UC1 image");
  }
  const cv::Rect inside(kResponseContextPx, kResponseContextPx, image.cols - 2 * kResponseContextPx,
                        image.rows - 2 * kResponseContextPx);
  if (roi.width > 0 && roi.height > 0 && (roi & inside) != roi) {
    throw std::invalid_argument("shiTomasiResponse: roi must stay 2 px inside the image");
  }
  response->create(image.size(), CV_32FC1);
  if (roi.width <= 0 || roi.height <= 0) return;

  // Gradient products of three image rows (ring buffer, columns roi.x-1 .. roi.x+width) and
  // their column sums; all exact in 32 bits (|gradient| <= 1020, block sums <= 9 * 1020^2).
  const int w = roi.width + 2;
  std::vector<std::int32_t>& products = buffers->products;
  products.resize(static_cast<std::size_t>(12 * w));
  std::int32_t* const column_sums = products.data() + 9 * w;
  auto product_row = [&](int r) {
    std::int32_t* xx = products.data() + 3 * w * ((r - roi.y + 1) % 3);
    gradientProductRow(image.ptr<std::uint8_t>(r - 1) + roi.x - 1, image.ptr<std::uint8_t>(r) + roi.x - 1,
                       image.ptr<std::uint8_t>(r + 1) + roi.x - 1, w, xx, xx + w, xx + 2 * w);
  };
  std::vector<double>& row = buffers->row;
  row.resize(static_cast<std::size_t>(3 * roi.width));
  double* const discriminant = row.data();
  double* const determinant = discriminant + roi.width;
  double* const trace = determinant + roi.width;
  const double eigen_scale = 2.0 * kGradientScale * kGradientScale;
  product_row(roi.y - 1);
  product_row(roi.y);
  for (int y = roi.y; y < roi.y + roi.height; ++y) {
    product_row(y + 1);
    const std::int32_t* s0 = products.data();
    const std::int32_t* s1 = s0 + 3 * w;
    const std::int32_t* s2 = s1 + 3 * w;
    for (int i = 0; i < 3 * w; ++i) column_sums[i] = s0[i] + s1[i] + s2[i];  // the three slots, any order
    const std::int32_t* cxx = column_sums;
    const std::int32_t* cxy = cxx + w;
    const std::int32_t* cyy = cxy + w;
    for (int x = 0; x < roi.width; ++x) {
      // Block sums (< 2^24) and their products (< 2^47) are exact in double.
      const double sxx = cxx[x] + cxx[x + 1] + cxx[x + 2];
      const double sxy = cxy[x] + cxy[x + 1] + cxy[x + 2];
      const double syy = cyy[x] + cyy[x + 1] + cyy[x + 2];
      // Eigenvalues of [sxx sxy; sxy syy]: (T -+ sqrt(T^2 - 4 det)) / 2 with T^2 - 4 det =
      // (sxx - syy)^2 + 4 sxy^2; the smaller one is 2 det / (T + sqrt(...)).
      discriminant[x] = (sxx - syy) * (sxx - syy) + 4.0 * sxy * sxy;
      determinant[x] = sxx * syy - sxy * sxy;
      // The trace is an integer, 0 only without any gradient (then det = 0 and the response is
      // 0 / 1 = 0); the +1 there keeps the division below free of a branch (and vectorised).
      const std::int32_t trace_sum = cxx[x] + cxx[x + 1] + cxx[x + 2] + cyy[x] + cyy[x + 1] + cyy[x + 2];
      trace[x] = trace_sum + (trace_sum == 0);
    }
    cv::hal::sqrt64f(discriminant, discriminant, roi.width);
    float* out = response->ptr<float>(y) + roi.x;
    for (int x = 0; x < roi.width; ++x) {
      out[x] = static_cast<float>(eigen_scale * determinant[x] / (trace[x] + discriminant[x]));
    }
  }
}

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
  // The response is computed one pixel beyond the border (the 3x3 maximum looks there), and it
  // needs its own context beyond that.
  const int border = std::max(border_px, kResponseContextPx + 1);
  if (image.cols <= 2 * border || image.rows <= 2 * border) return result;

  CornerResponseBuffers local_buffers;
  CornerResponseBuffers& work = buffers ? *buffers : local_buffers;
  cv::Mat& response = work.response;
  const cv::Rect inner(border, border, image.cols - 2 * border, image.rows - 2 * border);
  const cv::Rect with_ring(inner.x - 1, inner.y - 1, inner.width + 2, inner.height + 2);
  shiTomasiResponse(image, with_ring, &response, &work);
  double strongest = 0.0;
  cv::minMaxLoc(response(inner), nullptr, &strongest);
  result.max_response = static_cast<float>(strongest);
  const double threshold = std::max(min_response, min_quality_level * strongest);
  if (!(strongest > 0.0) || strongest < threshold) return result;

  for (int y = inner.y; y < inner.y + inner.height; ++y) {
    const float* above = response.ptr<float>(y - 1);
    const float* r = response.ptr<float>(y);
    const float* below = response.ptr<float>(y + 1);
    const std::uint8_t* free = free_mask.empty() ? nullptr : free_mask.ptr<std::uint8_t>(y);
    const int x_end = inner.x + inner.width;
    for (int x = inner.x; x < x_end; ++x) {
      // The mask first: the tracks' discs cover most of the image, so whole occupied 8-pixel
      // words are skipped at once.
      if (free) {
        std::uint64_t word = 1;
        if (x + 8 <= x_end) std::memcpy(&word, free + x, sizeof(word));
        if (word == 0) {
          x += 7;
          continue;
        }
        if (!free[x]) continue;
      }
      if (r[x] >= threshold && isLocalMaximum(above, r, below, x)) {
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

void flattenIllumination(const cv::Mat& image, double sigma_px, int downsample, double target_mean, cv::Mat* out,
                         IlluminationBuffers* buffers) {
  CV_Assert(image.type() == CV_8UC1 && sigma_px > 0.0 && downsample >= 1 && out != &image);
  const double scale = 1.0 / downsample;
  cv::resize(image, buffers->small_u8, cv::Size(), scale, scale, cv::INTER_AREA);
  buffers->small_u8.convertTo(buffers->small, CV_32F);
  const double sigma_small = sigma_px * scale;
  cv::GaussianBlur(buffers->small, buffers->low_small, cv::Size(0, 0), sigma_small, 0, cv::BORDER_CONSTANT);
  if (buffers->coverage.size() != buffers->small.size()) {
    const cv::Mat ones(buffers->small.size(), CV_32F, cv::Scalar(1.0));
    cv::GaussianBlur(ones, buffers->coverage, cv::Size(0, 0), sigma_small, 0, cv::BORDER_CONSTANT);
  }
  cv::divide(buffers->low_small, buffers->coverage, buffers->low_small);
  // The gain is formed at the low resolution (cheap) and then upsampled: the division at full
  // resolution is a multiplication by a smooth field.
  cv::max(buffers->low_small, 1.0, buffers->low_small);
  cv::divide(target_mean, buffers->low_small, buffers->low_small);
  cv::resize(buffers->low_small, buffers->gain, image.size(), 0, 0, cv::INTER_LINEAR);
  // 8-bit x float gain, rounded and saturated to 8 bits.
  cv::multiply(image, buffers->gain, *out, 1.0, CV_8U);
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
    fundamental =
        cv::findFundamentalMat(previous_px, current_px, cv::FM_RANSAC, threshold_px, confidence, max_iterations, mask);
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
