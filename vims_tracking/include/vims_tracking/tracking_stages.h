#pragma once
/// @file tracking_stages.h
/// @brief The building blocks FeatureTracker chains together: Shi-Tomasi corner candidates,
/// adaptive-quality corner selection under a minimum-distance mask, the long-tracks-first
/// minimum-distance thinning of existing tracks, and the epipolar RANSAC. They are public so
/// each can be tested (and reused, e.g. by a stereo front end) on its own.

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace vims {

/// One local maximum of the Shi-Tomasi response (minimum eigenvalue of the structure tensor).
struct CornerCandidate {
  cv::Point2f pixel;
  float response = 0.0f;
};

/// The Shi-Tomasi local maxima of one image (in raster order, not sorted: selectCorners() sorts
/// only the quality tiers it actually visits, usually a few hundred of ~10k candidates).
struct CornerCandidates {
  std::vector<CornerCandidate> candidates;
  float max_response = 0.0f;  ///< strongest response inside the border (0 if none)
};

/// Buffers findCornerCandidates() can reuse from frame to frame: allocating these multi-megabyte
/// images afresh every frame cost page faults that doubled the detection time on tank30.
struct CornerResponseBuffers {
  cv::Mat response;
  std::vector<std::int32_t> products;  ///< 3 rows x 3 gradient products (ring buffer)
  std::vector<double> row;             ///< one row of structure-tensor invariants
};

/// The Shi-Tomasi response of OpenCV's cv::cornerMinEigenVal(image, response, 3, 3) (3x3 Sobel
/// gradients, their products summed over a 3x3 block, minimum eigenvalue of the structure
/// tensor, 8-bit scale) at the pixels of `roi`, written into `response` (CV_32FC1 of the image
/// size; pixels outside `roi` are left as they are). `roi` must stay 2 px inside the image (the
/// gradient and the block each need one pixel of context), so no border extrapolation is done.
/// The gradients and block sums are exact integers and the eigenvalue is taken as
/// 2 det / (trace + sqrt(trace^2 - 4 det)), which is free of cancellation; it agrees with OpenCV
/// to float rounding (~1e-6 relative) at less than half the cost (no float filter passes).
void shiTomasiResponse(const cv::Mat& image, const cv::Rect& roi, cv::Mat* response, CornerResponseBuffers* buffers);

/// Computes the Shi-Tomasi response (block 3, aperture 3) of an 8-bit mono image and keeps the
/// 3x3 local maxima that are at least `border_px` inside the image, lie where `free_mask`
/// (CV_8UC1, optional) is non-zero, and whose response is at least
/// max(min_response, min_quality_level * strongest response). The strongest response is taken
/// over the whole image (inside the border), so the relative levels do not depend on the mask.
CornerCandidates findCornerCandidates(const cv::Mat& image, int border_px, double min_response,
                                      double min_quality_level, const cv::Mat& free_mask = cv::Mat(),
                                      CornerResponseBuffers* buffers = nullptr);

/// Adaptive-quality selection parameters (see TrackerOptions).
struct CornerSelectionParams {
  int max_corners = 150;
  double min_distance_px = 30.0;
  double quality_level = 0.01;
  double min_quality_level = 0.0005;
  double quality_decrease_factor = 0.25;
};

struct CornerSelection {
  std::vector<cv::Point2f> corners;  ///< strongest first
  /// The lowest relative quality level that was needed (quality_level if it sufficed).
  double quality_level_reached = 0.0;
};

/// Greedy Shi-Tomasi selection: takes candidates strongest first where `occupancy` (CV_8UC1,
/// non-zero = free) is free, and marks a disc of radius min_distance_px around each taken corner
/// as occupied. Starts at `quality_level` (relative to max_response); while fewer than
/// max_corners were found, lowers the level by `quality_decrease_factor` down to
/// `min_quality_level` and continues. Lowering the level only adds corners, so the candidates
/// are computed once per frame. Ties in response are taken in raster order (deterministic).
CornerSelection selectCorners(CornerCandidates candidates, const CornerSelectionParams& params, cv::Mat* occupancy);

/// Minimum-distance thinning of existing tracks: visits the points longest track first (ties:
/// lowest index first) and keeps a point only if no kept point lies within min_distance_px;
/// marks a disc around each kept point in `occupancy` (CV_8UC1 of the image size, 255 = free,
/// points outside the image are dropped). Returns the kept indices in ascending order.
std::vector<std::size_t> thinByDistanceLongestFirst(const std::vector<cv::Point2f>& pixels,
                                                    const std::vector<int>& track_lengths, double min_distance_px,
                                                    cv::Mat* occupancy);

/// Buffers flattenIllumination() reuses from frame to frame (no per-frame allocation).
struct IlluminationBuffers {
  cv::Mat small_u8;   ///< area-downsampled image
  cv::Mat small;      ///< the same, float
  cv::Mat low_small;  ///< its Gaussian low-pass
  cv::Mat coverage;   ///< the same low-pass of an all-ones image (zero outside): the border weights
  cv::Mat gain;       ///< target / low-pass, upsampled to the image size, float
};

/// Removes the illumination that is fixed to the camera (a lamp's beam, its 1/r^2 fall-off,
/// vignetting) from an 8-bit mono image: out = clamp(target_mean * image / L, 0, 255), where L is
/// the image's local mean, a Gaussian low-pass of standard deviation `sigma_px` (computed on a copy
/// area-downsampled by `downsample`, then bilinearly upsampled; floored at 1 grey level). What
/// remains is the seabed's reflectance pattern, which moves with the scene, so a seabed point keeps
/// its grey level as it crosses the image (KLT's brightness constancy); dark frames are equalised
/// to `target_mean` on the way. `out` may not alias `image`.
void flattenIllumination(const cv::Mat& image, double sigma_px, int downsample, double target_mean, cv::Mat* out,
                         IlluminationBuffers* buffers);

/// Outcome of the epipolar check on one set of correspondences.
struct EpipolarCheck {
  std::vector<std::uint8_t> inlier;  ///< 1 = consistent with the fundamental matrix
  bool performed = false;            ///< false when too few correspondences (all kept)
};

/// Fundamental-matrix RANSAC on undistorted normalised coordinates. They are mapped to a virtual
/// pinhole camera with focal length `focal_px` (and the principal point at the origin) so that
/// `threshold_px` is a pixel distance to the epipolar line, independent of the lens distortion.
/// Needs at least 15 correspondences; with fewer, every correspondence is kept (performed = false).
EpipolarCheck epipolarRansac(const std::vector<Eigen::Vector2d>& previous_normalized,
                             const std::vector<Eigen::Vector2d>& current_normalized, double focal_px,
                             double threshold_px, double confidence, int max_iterations);

}  // namespace vims
