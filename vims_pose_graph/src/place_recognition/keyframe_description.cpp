#include "vims_pose_graph/keyframe_description.h"

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <unordered_map>

#include "vims_common/camera_model.h"

namespace vims {

namespace {
/// cv::ORB's border for detection and description (FeatureExtractor uses edgeThreshold 31 and a
/// 31 px patch); replicated keypoints closer to the level-0 border are dropped, as ORB does.
constexpr int kOrbEdgeThreshold = 31;
constexpr int kOrbPatchSize = 31;
constexpr int kOrbHalfPatch = kOrbPatchSize / 2;
constexpr int kHarrisBlock = 7;
}  // namespace

void mergeDescribedPoints(DescribedPoints* local, const DescribedPoints& older) {
  std::unordered_map<uint64_t, uint32_t> index_of;
  for (uint32_t i = 0; i < local->feature_id.size(); ++i) index_of.emplace(local->feature_id[i], i);
  std::vector<uint32_t> new_index(older.numPoints());
  for (uint32_t i = 0; i < older.numPoints(); ++i) {
    const auto it = index_of.find(older.feature_id[i]);
    if (it != index_of.end()) {
      new_index[i] = it->second;
      continue;
    }
    new_index[i] = static_cast<uint32_t>(local->p_odom.size());
    index_of.emplace(older.feature_id[i], new_index[i]);
    local->feature_id.push_back(older.feature_id[i]);
    local->p_odom.push_back(older.p_odom[i]);
    local->pixel.push_back(older.pixel[i]);
  }
  for (size_t d = 0; d < older.descriptors.size(); ++d) {
    local->descriptors.push_back(older.descriptors[d]);
    local->point_of_descriptor.push_back(new_index[older.point_of_descriptor[d]]);
    local->level_of_descriptor.push_back(older.level_of_descriptor[d]);
  }
}

cv::Mat toMono8(const cv::Mat& image) {
  if (image.empty()) return cv::Mat();
  if (image.type() == CV_8UC1) return image;
  if (image.type() == CV_8UC3) {
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    return grey;
  }
  return cv::Mat();
}

double harrisResponse(const cv::Mat& image, const cv::Point2f& pt, int block_size, double k) {
  const int r = block_size / 2;
  const int x0 = cvRound(pt.x);
  const int y0 = cvRound(pt.y);
  // The block plus one pixel for the 3x3 Sobel stencil must be inside the image.
  if (x0 - r - 1 < 0 || y0 - r - 1 < 0 || x0 + r + 1 >= image.cols || y0 + r + 1 >= image.rows) return 0.0;
  // Integer sums (|Sobel| <= 1020, so < 2^31 up to 2000 px blocks): exact, i.e. the same values
  // a floating-point sum of these integers gives, computed faster.
  int64_t sum_xx = 0, sum_yy = 0, sum_xy = 0;
  for (int y = y0 - r; y <= y0 + r; ++y) {
    const uint8_t* up = image.ptr<uint8_t>(y - 1);
    const uint8_t* mid = image.ptr<uint8_t>(y);
    const uint8_t* down = image.ptr<uint8_t>(y + 1);
    int row_xx = 0, row_yy = 0, row_xy = 0;
    for (int x = x0 - r; x <= x0 + r; ++x) {
      const int ix = (up[x + 1] - up[x - 1]) + 2 * (mid[x + 1] - mid[x - 1]) + (down[x + 1] - down[x - 1]);
      const int iy = (down[x - 1] - up[x - 1]) + 2 * (down[x] - up[x]) + (down[x + 1] - up[x + 1]);
      row_xx += ix * ix;
      row_yy += iy * iy;
      row_xy += ix * iy;
    }
    sum_xx += row_xx;
    sum_yy += row_yy;
    sum_xy += row_xy;
  }
  const double a = static_cast<double>(sum_xx), b = static_cast<double>(sum_yy), c = static_cast<double>(sum_xy);
  // cv::ORB scales each gradient by 1 / (4 * block * 255) (Sobel gain 4, block sum, 8-bit
  // range): the response is a 4th power of that scale.
  const double s = 1.0 / (4.0 * block_size * 255.0);
  const double s4 = s * s * s * s;
  return (a * b - c * c - k * (a + b) * (a + b)) * s4;
}

namespace {
/// Half-widths of the rows of a digital disc of `radius`, made symmetric under swapping x and y
/// (the rows near the top take the extents of the columns near the side). This is the patch
/// shape cv::ORB measures orientation on; using the same shape keeps a replicated keypoint's
/// angle, and so its steered descriptor, equal to ORB's for the same corner (a plain
/// x^2 + y^2 <= r^2 disc differs in the outer rows and shifts weak centroids by several degrees).
std::vector<int> discRowExtents(int radius) {
  std::vector<int> extent(static_cast<size_t>(radius) + 2, 0);
  const double diagonal = radius * std::sqrt(2.0) / 2.0;
  const int lower_rows = static_cast<int>(std::floor(diagonal + 1.0));
  const int upper_first = static_cast<int>(std::ceil(diagonal));
  for (int v = 0; v <= lower_rows; ++v)
    extent[static_cast<size_t>(v)] = cvRound(std::sqrt(static_cast<double>(radius) * radius - v * v));
  int column = 0;
  for (int v = radius; v >= upper_first; --v) {
    while (extent[static_cast<size_t>(column)] == extent[static_cast<size_t>(column) + 1]) ++column;
    extent[static_cast<size_t>(v)] = column;
    ++column;
  }
  return extent;
}
}  // namespace

double intensityCentroidAngleDeg(const cv::Mat& image, const cv::Point2f& pt, int radius) {
  const int x0 = cvRound(pt.x);
  const int y0 = cvRound(pt.y);
  if (radius < 1 || x0 - radius < 0 || y0 - radius < 0 || x0 + radius >= image.cols || y0 + radius >= image.rows)
    return -1.0;
  // ORB's patch radius is by far the most frequent (every replicated keypoint): its extents are
  // computed once, not per keypoint.
  static const std::vector<int> kOrbPatchExtent = discRowExtents(kOrbHalfPatch);
  const std::vector<int> other_extent = radius == kOrbHalfPatch ? std::vector<int>() : discRowExtents(radius);
  const std::vector<int>& extent = radius == kOrbHalfPatch ? kOrbPatchExtent : other_extent;
  // Integer moments: exact (|sum| < 2^31 for any radius a patch of an image can have), so the
  // same values as floating-point sums of these integers, computed faster.
  int64_t m10 = 0, m01 = 0;
  for (int dy = -radius; dy <= radius; ++dy) {
    const uint8_t* row = image.ptr<uint8_t>(y0 + dy) + x0;
    const int w = extent[static_cast<size_t>(std::abs(dy))];
    int row_sum = 0, row_moment = 0;
    for (int dx = -w; dx <= w; ++dx) {
      const int v = row[dx];
      row_moment += dx * v;
      row_sum += v;
    }
    m10 += row_moment;
    m01 += static_cast<int64_t>(dy) * row_sum;
  }
  // Image coordinates (y down), degrees in [0, 360): what cv::ORB stores in KeyPoint::angle and
  // what its descriptor uses to steer the test pattern.
  double angle = std::atan2(static_cast<double>(m01), static_cast<double>(m10)) * 180.0 / M_PI;
  if (angle < 0.0) angle += 360.0;
  if (angle >= 360.0) angle -= 360.0;
  return angle;
}

std::vector<Eigen::Vector2d> undistortPixels(const CameraCalibration& camera, const std::vector<cv::Point2f>& pixels) {
  const CameraModel model(camera);
  std::vector<Eigen::Vector2d> out;
  out.reserve(pixels.size());
  for (const cv::Point2f& p : pixels) {
    const Eigen::Vector2d pixel(p.x, p.y);
    // The inverse fails only where a lens folds over, never inside the image of a usable
    // calibration (test_camera_model); the undistorted pinhole ray then keeps the list aligned.
    const std::optional<Eigen::Vector2d> m = model.normalizedFromPixel(pixel);
    out.push_back(m ? *m : Eigen::Vector2d((pixel.x() - camera.cx) / camera.fx, (pixel.y() - camera.cy) / camera.fy));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// KeyframeDescriber
// ---------------------------------------------------------------------------------------------

// ---------------------------------------------------------------------------------------------
// Pyramid and Shi-Tomasi corners
// ---------------------------------------------------------------------------------------------

std::vector<cv::Mat> buildOrbPyramid(const cv::Mat& mono, double scale_factor, int levels) {
  std::vector<cv::Mat> pyramid;
  if (mono.empty() || levels < 1) return pyramid;
  pyramid.reserve(static_cast<size_t>(levels));
  pyramid.push_back(mono);
  for (int level = 1; level < levels; ++level) {
    const double scale = std::pow(scale_factor, level);
    const cv::Size size(cvRound(mono.cols / scale), cvRound(mono.rows / scale));
    if (size.width < 2 * kOrbHalfPatch + 2 || size.height < 2 * kOrbHalfPatch + 2) break;
    cv::Mat next;
    cv::resize(pyramid.back(), next, size, 0, 0, cv::INTER_LINEAR_EXACT);
    pyramid.push_back(next);
  }
  return pyramid;
}

namespace {
/// Maps a float to an unsigned key with the same order (sign bit flipped for positives, all bits
/// for negatives), so (response, pixel index) pairs sort as single integers.
uint32_t orderedBits(float value) {
  uint32_t bits = 0;
  std::memcpy(&bits, &value, sizeof(bits));
  return (bits & 0x80000000u) != 0 ? ~bits : (bits | 0x80000000u);
}
}  // namespace

ShiTomasiCandidates::ShiTomasiCandidates(const cv::Mat& mono, double quality_level, int block_size)
    : image_size_(mono.size()) {
  if (mono.rows < 3 || mono.cols < 3) return;
  // The first half of cv::goodFeaturesToTrack (OpenCV 4.6, featureselect.cpp), step by step.
  cv::Mat response, dilated;
  cv::cornerMinEigenVal(mono, response, block_size, 3);
  double max_response = 0.0;
  cv::minMaxLoc(response, nullptr, &max_response);
  cv::threshold(response, response, max_response * quality_level, 0, cv::THRESH_TOZERO);
  cv::dilate(response, dilated, cv::Mat());
  // Every inner pixel's key is written and kept only if it is a non-zero local maximum: without
  // a data-dependent branch (about one pixel in six qualifies, unpredictably).
  keys_.resize(static_cast<size_t>(mono.rows - 2) * static_cast<size_t>(mono.cols - 2) + 1);
  size_t n = 0;
  for (int y = 1; y < mono.rows - 1; ++y) {
    const float* r = response.ptr<float>(y);
    const float* d = dilated.ptr<float>(y);
    const uint32_t row_index = static_cast<uint32_t>(y * mono.cols);
    for (int x = 1; x < mono.cols - 1; ++x) {
      keys_[n] = (uint64_t{orderedBits(r[x])} << 32) | (row_index + static_cast<uint32_t>(x));
      n += static_cast<size_t>((r[x] != 0.0f) & (r[x] == d[x]));
    }
  }
  keys_.resize(n);
}

void ShiTomasiCandidates::sortFirst(size_t n) {
  n = std::min(n, keys_.size());
  if (n <= sorted_) return;
  const auto begin = keys_.begin() + static_cast<std::ptrdiff_t>(sorted_);
  const auto middle = keys_.begin() + static_cast<std::ptrdiff_t>(n);
  // The keys are distinct (pixel index), so this prefix is the full sort's prefix.
  if (middle != keys_.end()) std::nth_element(begin, middle, keys_.end(), std::greater<uint64_t>());
  std::sort(begin, middle, std::greater<uint64_t>());
  sorted_ = n;
}

cv::Point ShiTomasiCandidates::pixelOf(size_t i) const {
  const int index = static_cast<int>(keys_[i] & 0xffffffffu);
  return cv::Point(index % image_size_.width, index / image_size_.width);
}

std::vector<cv::Point2f> ShiTomasiCandidates::select(int max_corners, double min_distance) {
  // The second half of cv::goodFeaturesToTrack: greedy in response order, a candidate is taken
  // unless a taken one lies within min_distance (checked in the 3x3 cells of a min_distance grid).
  std::vector<cv::Point2f> corners;
  const size_t limit = max_corners > 0 ? static_cast<size_t>(max_corners) : keys_.size();
  // Sorted in growing chunks: a selection usually ends after a few times `limit` candidates.
  auto ensureSorted = [&](size_t i) {
    if (i >= sorted_) sortFirst(std::max(2 * sorted_, i + 4 * limit + 1024));
  };
  if (!(min_distance >= 1.0)) {
    for (size_t i = 0; i < keys_.size() && corners.size() < limit; ++i) {
      ensureSorted(i);
      const cv::Point p = pixelOf(i);
      corners.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
    }
    return corners;
  }
  const int cell_size = cvRound(min_distance);
  const int grid_width = (image_size_.width + cell_size - 1) / cell_size;
  const int grid_height = (image_size_.height + cell_size - 1) / cell_size;
  // The taken corners of each cell as linked lists through `next_in_cell` (OpenCV keeps a vector
  // per cell: tens of thousands of allocations per selection). Whether any taken corner is too
  // close does not depend on the order they are visited in.
  std::vector<int> cell_head(static_cast<size_t>(grid_width) * static_cast<size_t>(grid_height), -1);
  std::vector<int> next_in_cell;
  const double min_distance_sq = min_distance * min_distance;
  for (size_t i = 0; i < keys_.size(); ++i) {
    ensureSorted(i);
    const cv::Point p = pixelOf(i);
    const int x_cell = p.x / cell_size;
    const int y_cell = p.y / cell_size;
    bool good = true;
    for (int yy = std::max(0, y_cell - 1); good && yy <= std::min(grid_height - 1, y_cell + 1); ++yy) {
      for (int xx = std::max(0, x_cell - 1); good && xx <= std::min(grid_width - 1, x_cell + 1); ++xx) {
        for (int q = cell_head[static_cast<size_t>(yy * grid_width + xx)]; q >= 0;
             q = next_in_cell[static_cast<size_t>(q)]) {
          // float differences compared in double, as OpenCV does (identical ties at the limit)
          const float dx = static_cast<float>(p.x) - corners[static_cast<size_t>(q)].x;
          const float dy = static_cast<float>(p.y) - corners[static_cast<size_t>(q)].y;
          if (dx * dx + dy * dy < min_distance_sq) {
            good = false;
            break;
          }
        }
      }
    }
    if (!good) continue;
    int& head = cell_head[static_cast<size_t>(y_cell * grid_width + x_cell)];
    next_in_cell.push_back(head);
    head = static_cast<int>(corners.size());
    corners.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
    if (corners.size() == limit) break;
  }
  return corners;
}

namespace {
/// The tracker's Shi-Tomasi settings (vims_estimator's corner detection): 0.1 % of the strongest
/// response, 3x3 blocks.
constexpr double kShiTomasiQuality = 0.001;
constexpr int kShiTomasiBlock = 3;
}  // namespace

KeyframeImage::KeyframeImage(const cv::Mat& image, double scale_factor, int levels)
    : mono_(toMono8(image)), pyramid_(buildOrbPyramid(mono_, scale_factor, levels)), scale_factor_(scale_factor) {
  candidates_.resize(pyramid_.size());
}

std::vector<cv::Point2f> KeyframeImage::cornersOnLevel(int level, int max_corners, double min_distance_px) {
  std::vector<cv::Point2f> corners;
  if (level < 0 || level >= static_cast<int>(pyramid_.size()) || max_corners <= 0) return corners;
  std::unique_ptr<ShiTomasiCandidates>& candidates = candidates_[static_cast<size_t>(level)];
  if (!candidates)
    candidates =
        std::make_unique<ShiTomasiCandidates>(pyramid_[static_cast<size_t>(level)], kShiTomasiQuality, kShiTomasiBlock);
  corners = candidates->select(max_corners, min_distance_px);
  // cv::ORB's convention for its own keypoints (level pixel x scale), so both kinds agree.
  const float scale = static_cast<float>(std::pow(scale_factor_, level));
  for (cv::Point2f& c : corners) c *= scale;
  return corners;
}

// ---------------------------------------------------------------------------------------------
// KeyframeDescriber
// ---------------------------------------------------------------------------------------------

/// ORB keypoints of several DescribedPoints (tracked points, dense corners per level, seabed
/// corners per level), described by ONE cv::ORB::compute call: each call builds, borders and
/// blurs ORB's whole pyramid, which cost more than the descriptors themselves. A descriptor
/// depends only on its keypoint and its level's image, so batching does not change it.
class KeyframeDescriber::OrbBatch {
 public:
  /// Queues a keypoint whose descriptor belongs to point `point` of *target on level `level`.
  void add(cv::KeyPoint keypoint, DescribedPoints* target, uint32_t point, int level) {
    keypoint.class_id = static_cast<int>(owners_.size());
    keypoints_.push_back(keypoint);
    owners_.push_back(Owner{target, point, level});
  }

  /// Computes every queued descriptor and appends each to its target, in the order queued.
  void compute(cv::ORB& orb, const cv::Mat& mono) {
    if (keypoints_.empty()) return;
    cv::Mat descriptors;
    orb.compute(mono, keypoints_, descriptors);
    const std::vector<BinaryDescriptor> d = descriptorsFromMat(descriptors);
    if (d.size() != keypoints_.size()) throw std::logic_error("KeyframeDescriber: ORB returned mismatched descriptors");
    // cv::ORB groups provided keypoints by level (stably) and drops those in its border;
    // class_id restores the queue order, which within one target is level by level: the order
    // one compute call per target returned.
    std::vector<size_t> order(keypoints_.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(),
              [&](size_t a, size_t b) { return keypoints_[a].class_id < keypoints_[b].class_id; });
    for (const size_t i : order) {
      const Owner& o = owners_.at(static_cast<size_t>(keypoints_[i].class_id));
      o.target->descriptors.push_back(d[i]);
      o.target->point_of_descriptor.push_back(o.point);
      o.target->level_of_descriptor.push_back(o.level);
    }
    keypoints_.clear();
    owners_.clear();
  }

 private:
  struct Owner {
    DescribedPoints* target;
    uint32_t point;
    int level;
  };
  std::vector<cv::KeyPoint> keypoints_;  ///< class_id = index into owners_
  std::vector<Owner> owners_;
};

KeyframeDescriber::KeyframeDescriber(const FeatureExtractionOptions& features, double harris_threshold,
                                     const CameraCalibration& camera, bool include_tracked_corners)
    : features_(features),
      harris_threshold_(harris_threshold),
      include_tracked_corners_(include_tracked_corners),
      camera_(camera),
      extractor_(features) {
  if (!(harris_threshold >= 0.0)) throw std::invalid_argument("KeyframeDescriber: harris_threshold must be >= 0");
  if (!(camera.fx > 0.0) || !(camera.fy > 0.0))
    throw std::invalid_argument("KeyframeDescriber: camera intrinsics must be positive");
  // Same ORB settings as FeatureExtractor (feature_extraction.cpp), so a replicated keypoint's
  // descriptor is what ORB computes for a detected keypoint at that place, level and angle.
  orb_ = cv::ORB::create(features.max_features, static_cast<float>(features.orb_scale_factor), features.orb_levels,
                         kOrbEdgeThreshold, 0, 2, cv::ORB::HARRIS_SCORE, kOrbPatchSize, features.fast_threshold);
}

KeyframeImage KeyframeDescriber::prepare(const cv::Mat& image) const {
  // BRIEF is single scale: no pyramid beyond the image itself.
  return KeyframeImage(image, features_.orb_scale_factor,
                       features_.descriptor == DescriptorType::kOrb ? features_.orb_levels : 1);
}

VisualSubmap KeyframeDescriber::describeImage(const cv::Mat& image, const BinaryVocabulary* vocabulary) {
  VisualSubmap submap;
  const cv::Mat mono = toMono8(image);
  if (mono.empty()) return submap;
  ImageFeatures f = extractor_.extract(mono);
  if (f.keypoints.empty() || f.keypoints.size() != f.descriptors.size()) return submap;
  submap.keypoints = std::move(f.keypoints);
  submap.descriptors = std::move(f.descriptors);
  std::vector<cv::Point2f> pixels;
  pixels.reserve(submap.keypoints.size());
  for (const cv::KeyPoint& kp : submap.keypoints) pixels.push_back(kp.pt);
  submap.normalized = undistortPixels(camera_, pixels);
  if (vocabulary != nullptr && !vocabulary->empty()) submap.bow = vocabulary->transform(submap.descriptors);
  return submap;
}

void KeyframeDescriber::setDenseCorners(int max_corners, double min_distance_px, int max_level) {
  if (max_corners < 0 || !(min_distance_px >= 1.0) || max_level < 0)
    throw std::invalid_argument("KeyframeDescriber::setDenseCorners: invalid arguments");
  dense_corners_ = max_corners;
  dense_min_distance_px_ = min_distance_px;
  dense_max_level_ = max_level;
}

void KeyframeDescriber::setSeabedCorners(int max_corners, double min_distance_px, int max_level) {
  if (max_corners < 0 || !(min_distance_px >= 1.0) || max_level < 0)
    throw std::invalid_argument("KeyframeDescriber::setSeabedCorners: invalid arguments");
  seabed_corners_ = max_corners;
  seabed_min_distance_px_ = min_distance_px;
  seabed_max_level_ = max_level;
}

namespace {
/// Appends replicated point descriptors (up to max_level) to a submap's matching keypoints.
/// Their angle is -1 (not detected by ORB) and the octave is the replication level.
void appendReplicated(const DescribedPoints& described, int max_level, double scale_factor,
                      const CameraCalibration& camera, VisualSubmap* submap) {
  std::vector<cv::Point2f> pixels;
  for (size_t d = 0; d < described.descriptors.size(); ++d) {
    const int level = described.level_of_descriptor[d];
    if (level > max_level) continue;
    const Eigen::Vector2d& px = described.pixel[described.point_of_descriptor[d]];
    const float size = static_cast<float>(kOrbPatchSize * std::pow(scale_factor, level));
    submap->keypoints.emplace_back(cv::Point2f(static_cast<float>(px.x()), static_cast<float>(px.y())), size, -1.0f,
                                   0.0f, level);
    submap->descriptors.push_back(described.descriptors[d]);
    pixels.push_back(submap->keypoints.back().pt);
  }
  const std::vector<Eigen::Vector2d> normalized = undistortPixels(camera, pixels);
  submap->normalized.insert(submap->normalized.end(), normalized.begin(), normalized.end());
}

/// 2D-only landmarks at `corners` (the 3D position is not used for keypoints).
std::vector<KeyframeLandmark> pseudoLandmarks(const std::vector<cv::Point2f>& corners) {
  std::vector<KeyframeLandmark> pseudo;
  pseudo.reserve(corners.size());
  for (const cv::Point2f& c : corners) {
    KeyframeLandmark l;
    l.pixel = Eigen::Vector2d(c.x, c.y);
    pseudo.push_back(l);
  }
  return pseudo;
}
}  // namespace

VisualSubmap KeyframeDescriber::describeKeyframe(const cv::Mat& image, const std::vector<KeyframeLandmark>& features,
                                                 const BinaryVocabulary* vocabulary, DescribedPoints* points) {
  KeyframeImage prepared = prepare(image);
  KeyframeDescription d = describeAll(prepared, features, nullptr, vocabulary);
  if (points != nullptr) *points = std::move(d.points);
  return std::move(d.submap);
}

KeyframeDescription KeyframeDescriber::describeKeyframeAndSeabed(const cv::Mat& image,
                                                                 const std::vector<KeyframeLandmark>& features,
                                                                 const Eigen::Isometry3d& T_odom_c,
                                                                 const BinaryVocabulary* vocabulary) {
  KeyframeImage prepared = prepare(image);
  return describeAll(prepared, features, &T_odom_c, vocabulary);
}

KeyframeDescription KeyframeDescriber::describeAll(KeyframeImage& image, const std::vector<KeyframeLandmark>& features,
                                                   const Eigen::Isometry3d* T_odom_c,
                                                   const BinaryVocabulary* vocabulary) {
  KeyframeDescription out;
  // ORB's own keypoints come from FeatureExtractor (detection and description in one call).
  out.submap = describeImage(image.mono(), vocabulary);
  const bool orb = features_.descriptor == DescriptorType::kOrb;
  OrbBatch batch;
  out.points = usablePoints(image.mono(), features);
  if (orb)
    replicateOnLevels(image, &out.points, 0, std::numeric_limits<int>::max(), &batch);
  else
    describeBrief(image.mono(), &out.points);

  // Dense corners: one DescribedPoints per detection (unique_ptr: the batch keeps their addresses).
  std::vector<std::unique_ptr<DescribedPoints>> dense;
  std::vector<int> dense_max_level;  // replication levels appended to the submap, per entry of `dense`
  if (dense_corners_ > 0 && orb && !out.submap.empty() && dense_per_level_) {
    // The same detector on every level: a corner of the seabed seen from higher up (smaller in
    // the image) is found on the level where it has the size it has in the query.
    for (int level = 0; level <= dense_max_level_ && level < static_cast<int>(image.pyramid().size()); ++level) {
      const int n = static_cast<int>(std::lround(dense_corners_ / std::pow(features_.orb_scale_factor, 2.0 * level)));
      dense.push_back(std::make_unique<DescribedPoints>(
          usablePoints(image.mono(), pseudoLandmarks(image.cornersOnLevel(level, n, dense_min_distance_px_)))));
      replicateOnLevels(image, dense.back().get(), level, level, &batch);
      dense_max_level.push_back(level);
    }
  } else if (dense_corners_ > 0 && orb && !out.submap.empty()) {
    // The tracker's detector (Shi-Tomasi, block 3), densely: whichever corners the VIO happened
    // to track at the query, the candidate then has a keypoint at most of them.
    dense.push_back(std::make_unique<DescribedPoints>(
        usablePoints(image.mono(), pseudoLandmarks(image.cornersOnLevel(0, dense_corners_, dense_min_distance_px_)))));
    replicateOnLevels(image, dense.back().get(), 0, dense_max_level_, &batch);
    dense_max_level.push_back(dense_max_level_);
  }

  // The query's seabed corners: their 3D positions need only the tracked points' positions, so
  // they join the same compute call.
  std::vector<std::unique_ptr<DescribedPoints>> seabed;
  if (T_odom_c != nullptr && seabed_corners_ > 0 && orb && !out.submap.empty())
    queueSeabedCorners(image, out.points, *T_odom_c, seabed_corners_, seabed_min_distance_px_, seabed_max_level_,
                       &seabed, &batch);

  batch.compute(*orb_, image.mono());

  if (include_tracked_corners_ && !out.submap.empty() && !out.points.descriptors.empty())
    appendReplicated(out.points, std::numeric_limits<int>::max(), features_.orb_scale_factor, camera_, &out.submap);
  for (size_t i = 0; i < dense.size(); ++i)
    appendReplicated(*dense[i], dense_max_level[i], features_.orb_scale_factor, camera_, &out.submap);
  for (const std::unique_ptr<DescribedPoints>& level_points : seabed)
    mergeDescribedPoints(&out.seabed_points, *level_points);
  return out;
}

DescribedPoints KeyframeDescriber::describePoints(const cv::Mat& image, const std::vector<KeyframeLandmark>& features) {
  return describePoints(image, features, std::numeric_limits<int>::max());
}

DescribedPoints KeyframeDescriber::describePoints(const cv::Mat& image, const std::vector<KeyframeLandmark>& features,
                                                  int max_level) {
  KeyframeImage prepared = prepare(image);
  DescribedPoints out = usablePoints(prepared.mono(), features);
  if (features_.descriptor == DescriptorType::kOrb) {
    OrbBatch batch;
    replicateOnLevels(prepared, &out, 0, max_level, &batch);
    batch.compute(*orb_, prepared.mono());
  } else {
    describeBrief(prepared.mono(), &out);
  }
  return out;
}

DescribedPoints KeyframeDescriber::describeSeabedCorners(const cv::Mat& image, const DescribedPoints& tracked,
                                                         const Eigen::Isometry3d& T_odom_c, int max_corners,
                                                         double min_distance_px, int max_level) {
  DescribedPoints out;
  if (features_.descriptor != DescriptorType::kOrb) return out;
  KeyframeImage prepared = prepare(image);
  std::vector<std::unique_ptr<DescribedPoints>> per_level;
  OrbBatch batch;
  queueSeabedCorners(prepared, tracked, T_odom_c, max_corners, min_distance_px, max_level, &per_level, &batch);
  batch.compute(*orb_, prepared.mono());
  for (const std::unique_ptr<DescribedPoints>& level_points : per_level) mergeDescribedPoints(&out, *level_points);
  return out;
}

void KeyframeDescriber::queueSeabedCorners(KeyframeImage& image, const DescribedPoints& tracked,
                                           const Eigen::Isometry3d& T_odom_c, int max_corners, double min_distance_px,
                                           int max_level, std::vector<std::unique_ptr<DescribedPoints>>* per_level,
                                           OrbBatch* batch) const {
  if (image.empty() || max_corners <= 0 || max_level < 1 || features_.descriptor != DescriptorType::kOrb) return;
  // The tracked points in the camera: pixel, normalised coordinates, inverse depth.
  const Eigen::Isometry3d T_c_odom = T_odom_c.inverse();
  std::vector<Eigen::Vector2d> pixel, xy;
  std::vector<double> inverse_depth;
  for (size_t i = 0; i < tracked.numPoints(); ++i) {
    const Eigen::Vector3d p_c = T_c_odom * tracked.p_odom[i];
    if (!(p_c.z() > 1e-3) || !p_c.allFinite() || !tracked.pixel[i].allFinite()) continue;
    pixel.push_back(tracked.pixel[i]);
    xy.push_back(p_c.head<2>() / p_c.z());
    inverse_depth.push_back(1.0 / p_c.z());
  }
  if (pixel.size() < static_cast<size_t>(kNeighbours)) return;
  uint64_t next_id = uint64_t{1} << 63;
  for (int level = 1; level <= max_level && level < static_cast<int>(image.pyramid().size()); ++level) {
    const int n = static_cast<int>(std::lround(max_corners / std::pow(features_.orb_scale_factor, 2.0 * (level - 1))));
    const std::vector<cv::Point2f> corners = image.cornersOnLevel(level, n, min_distance_px);
    const std::vector<Eigen::Vector2d> normalized = undistortPixels(camera_, corners);
    std::vector<KeyframeLandmark> landmarks;
    for (size_t c = 0; c < corners.size(); ++c) {
      const Eigen::Vector2d px(corners[c].x, corners[c].y);
      // The kNeighbours nearest (distance, index) pairs in ascending order, by insertion: what
      // std::partial_sort gives (the pairs are distinct), without its heap over every point.
      std::array<std::pair<double, size_t>, kNeighbours> nearest;
      size_t found = 0;
      for (size_t i = 0; i < pixel.size(); ++i) {
        const std::pair<double, size_t> candidate((pixel[i] - px).squaredNorm(), i);
        if (found == nearest.size() && !(candidate < nearest.back())) continue;
        size_t slot = found < nearest.size() ? found++ : nearest.size() - 1;
        for (; slot > 0 && candidate < nearest[slot - 1]; --slot) nearest[slot] = nearest[slot - 1];
        nearest[slot] = candidate;
      }
      // Least squares of 1/z = a x + b y + c over the neighbours (3x3 normal equations).
      Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
      Eigen::Vector3d b = Eigen::Vector3d::Zero();
      double w_min = 1e300, w_max = 0.0;
      for (int k = 0; k < kNeighbours; ++k) {
        const size_t i = nearest[static_cast<size_t>(k)].second;
        const Eigen::Vector3d row(xy[i].x(), xy[i].y(), 1.0);
        A += row * row.transpose();
        b += row * inverse_depth[i];
        w_min = std::min(w_min, inverse_depth[i]);
        w_max = std::max(w_max, inverse_depth[i]);
      }
      const Eigen::FullPivLU<Eigen::Matrix3d> lu(A);
      if (lu.rank() < 3) continue;  // neighbours on a line: the plane is not determined
      const Eigen::Vector3d abc = lu.solve(b);
      const double w = abc.dot(Eigen::Vector3d(normalized[c].x(), normalized[c].y(), 1.0));
      const double margin = 0.5 * (w_max - w_min);
      if (!(w > 0.0) || w < w_min - margin || w > w_max + margin) continue;
      KeyframeLandmark l;
      l.id = next_id++;
      l.pixel = Eigen::Vector2d(corners[c].x, corners[c].y);
      l.normalized = normalized[c];
      l.p_odom = T_odom_c * (Eigen::Vector3d(normalized[c].x(), normalized[c].y(), 1.0) / w);
      landmarks.push_back(l);
    }
    per_level->push_back(std::make_unique<DescribedPoints>(usablePoints(image.mono(), landmarks)));
    replicateOnLevels(image, per_level->back().get(), level, level, batch);
  }
}

DescribedPoints KeyframeDescriber::usablePoints(const cv::Mat& mono, const std::vector<KeyframeLandmark>& features) {
  DescribedPoints out;
  if (mono.empty()) return out;
  // Points usable at all: finite, and (as cv::ORB requires) away from the level-0 border.
  for (const KeyframeLandmark& f : features) {
    if (!f.p_odom.allFinite() || !f.pixel.allFinite()) continue;
    if (f.pixel.x() < kOrbEdgeThreshold || f.pixel.y() < kOrbEdgeThreshold ||
        f.pixel.x() >= mono.cols - kOrbEdgeThreshold || f.pixel.y() >= mono.rows - kOrbEdgeThreshold)
      continue;
    out.feature_id.push_back(f.id);
    out.p_odom.push_back(f.p_odom);
    out.pixel.push_back(f.pixel);
  }
  return out;
}

void KeyframeDescriber::replicateOnLevels(const KeyframeImage& image, DescribedPoints* points, int min_level,
                                          int max_level, OrbBatch* batch) const {
  const std::vector<cv::Mat>& pyramid = image.pyramid();
  const int levels =
      static_cast<int>(std::min<size_t>(pyramid.size(), static_cast<size_t>(std::max(max_level, 0)) + 1));
  for (int level = std::max(min_level, 0); level < levels; ++level) {
    const cv::Mat& level_image = pyramid[static_cast<size_t>(level)];
    const double scale = std::pow(features_.orb_scale_factor, level);
    for (size_t u = 0; u < points->numPoints(); ++u) {
      const cv::Point2f pt0(static_cast<float>(points->pixel[u].x()), static_cast<float>(points->pixel[u].y()));
      const cv::Point2f pt_level(static_cast<float>(pt0.x / scale), static_cast<float>(pt0.y / scale));
      // Low Harris response on this level: the corner has blurred into an edge or a flat
      // patch here, and its descriptor would only add false matches.
      const double response = harrisResponse(level_image, pt_level, kHarrisBlock);
      if (response < harris_threshold_ || response <= 0.0) continue;
      const double angle = intensityCentroidAngleDeg(level_image, pt_level, kOrbHalfPatch);
      if (angle < 0.0) continue;
      batch->add(cv::KeyPoint(pt0, static_cast<float>(kOrbPatchSize * scale), static_cast<float>(angle),
                              static_cast<float>(response), level),
                 points, static_cast<uint32_t>(u), level);
    }
  }
}

void KeyframeDescriber::describeBrief(const cv::Mat& mono, DescribedPoints* points) const {
  // BRIEF is single scale and unoriented (the baseline): one descriptor per point.
  std::vector<cv::KeyPoint> keypoints;
  for (size_t u = 0; u < points->numPoints(); ++u) {
    const cv::Point2f pt(static_cast<float>(points->pixel[u].x()), static_cast<float>(points->pixel[u].y()));
    const double response = harrisResponse(mono, pt, kHarrisBlock);
    if (response < harris_threshold_ || response <= 0.0) continue;
    keypoints.emplace_back(pt, static_cast<float>(BriefDescriptor::kPatchSize), -1.0f, static_cast<float>(response), 0,
                           static_cast<int>(u));
  }
  if (keypoints.empty()) return;
  const std::vector<BinaryDescriptor> d = brief_.compute(mono, &keypoints);
  for (size_t i = 0; i < keypoints.size(); ++i) {
    points->descriptors.push_back(d[i]);
    points->point_of_descriptor.push_back(static_cast<uint32_t>(keypoints[i].class_id));
    points->level_of_descriptor.push_back(0);
  }
}

}  // namespace vims
