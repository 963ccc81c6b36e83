#include "vims_pose_graph/keyframe_description.h"

#include <Eigen/LU>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

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
  double a = 0.0, b = 0.0, c = 0.0;
  for (int y = y0 - r; y <= y0 + r; ++y) {
    const uint8_t* up = image.ptr<uint8_t>(y - 1);
    const uint8_t* mid = image.ptr<uint8_t>(y);
    const uint8_t* down = image.ptr<uint8_t>(y + 1);
    for (int x = x0 - r; x <= x0 + r; ++x) {
      const double ix = (up[x + 1] - up[x - 1]) + 2.0 * (mid[x + 1] - mid[x - 1]) + (down[x + 1] - down[x - 1]);
      const double iy = (down[x - 1] - up[x - 1]) + 2.0 * (down[x] - up[x]) + (down[x + 1] - up[x + 1]);
      a += ix * ix;
      b += iy * iy;
      c += ix * iy;
    }
  }
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
  const std::vector<int> extent = discRowExtents(radius);
  double m10 = 0.0, m01 = 0.0;
  for (int dy = -radius; dy <= radius; ++dy) {
    const uint8_t* row = image.ptr<uint8_t>(y0 + dy);
    const int w = extent[static_cast<size_t>(std::abs(dy))];
    for (int dx = -w; dx <= w; ++dx) {
      const double v = row[x0 + dx];
      m10 += dx * v;
      m01 += dy * v;
    }
  }
  // Image coordinates (y down), degrees in [0, 360): what cv::ORB stores in KeyPoint::angle and
  // what its descriptor uses to steer the test pattern.
  double angle = std::atan2(m01, m10) * 180.0 / M_PI;
  if (angle < 0.0) angle += 360.0;
  if (angle >= 360.0) angle -= 360.0;
  return angle;
}

std::vector<Eigen::Vector2d> undistortPixels(const CameraCalibration& camera, const std::vector<cv::Point2f>& pixels) {
  std::vector<Eigen::Vector2d> out;
  if (pixels.empty()) return out;
  const cv::Matx33d K(camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0);
  const cv::Vec4d D(camera.distortion[0], camera.distortion[1], camera.distortion[2], camera.distortion[3]);
  std::vector<cv::Point2f> normalized;
  // More iterations than OpenCV's default 5: keypoints near the corners of a wide lens need them
  // for sub-0.01 px accuracy, and this runs once per keypoint per keyframe.
  cv::undistortPoints(pixels, normalized, K, D, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-9));
  out.reserve(normalized.size());
  for (const cv::Point2f& p : normalized) out.emplace_back(p.x, p.y);
  return out;
}

bool projectToPixel(const CameraCalibration& camera, const Eigen::Vector3d& p_c, Eigen::Vector2d* pixel) {
  if (!(p_c.z() > 1e-9) || !p_c.allFinite()) return false;
  const double x = p_c.x() / p_c.z();
  const double y = p_c.y() / p_c.z();
  const double k1 = camera.distortion[0], k2 = camera.distortion[1];
  const double p1 = camera.distortion[2], p2 = camera.distortion[3];
  const double r2 = x * x + y * y;
  const double radial = 1.0 + k1 * r2 + k2 * r2 * r2;
  const double xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
  *pixel = Eigen::Vector2d(camera.fx * xd + camera.cx, camera.fy * yd + camera.cy);
  return true;
}

// ---------------------------------------------------------------------------------------------
// KeyframeDescriber
// ---------------------------------------------------------------------------------------------

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

std::vector<cv::Mat> KeyframeDescriber::buildPyramid(const cv::Mat& image) const {
  std::vector<cv::Mat> pyramid;
  pyramid.reserve(static_cast<size_t>(features_.orb_levels));
  pyramid.push_back(image);
  for (int level = 1; level < features_.orb_levels; ++level) {
    const double scale = std::pow(features_.orb_scale_factor, level);
    const cv::Size size(cvRound(image.cols / scale), cvRound(image.rows / scale));
    if (size.width < 2 * kOrbHalfPatch + 2 || size.height < 2 * kOrbHalfPatch + 2) break;
    cv::Mat next;
    cv::resize(pyramid.back(), next, size, 0, 0, cv::INTER_LINEAR_EXACT);
    pyramid.push_back(next);
  }
  return pyramid;
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
}  // namespace

VisualSubmap KeyframeDescriber::describeKeyframe(const cv::Mat& image, const std::vector<KeyframeLandmark>& features,
                                                const BinaryVocabulary* vocabulary, DescribedPoints* points) {
  VisualSubmap submap = describeImage(image, vocabulary);
  DescribedPoints described = describePoints(image, features);
  if (include_tracked_corners_ && !submap.empty() && !described.descriptors.empty())
    appendReplicated(described, std::numeric_limits<int>::max(), features_.orb_scale_factor, camera_, &submap);
  if (dense_corners_ > 0 && features_.descriptor == DescriptorType::kOrb && !submap.empty() && dense_per_level_) {
    // The same detector on every level: a corner of the seabed seen from higher up (smaller in
    // the image) is found on the level where it has the size it has in the query.
    const cv::Mat mono = toMono8(image);
    const std::vector<cv::Mat> pyramid = buildPyramid(mono);
    for (int level = 0; level <= dense_max_level_ && level < static_cast<int>(pyramid.size()); ++level) {
      const int n = static_cast<int>(std::lround(dense_corners_ / std::pow(features_.orb_scale_factor, 2.0 * level)));
      std::vector<KeyframeLandmark> pseudo;  // 2D only: the 3D position is not used for keypoints
      for (const cv::Point2f& c : cornersOnLevel(pyramid, level, n, dense_min_distance_px_)) {
        KeyframeLandmark l;
        l.pixel = Eigen::Vector2d(c.x, c.y);
        pseudo.push_back(l);
      }
      appendReplicated(describePointsOnLevels(mono, pseudo, level, level), level, features_.orb_scale_factor, camera_,
                       &submap);
    }
  } else if (dense_corners_ > 0 && features_.descriptor == DescriptorType::kOrb && !submap.empty()) {
    // The tracker's detector (Shi-Tomasi, block 3), densely: whichever corners the VIO happened
    // to track at the query, the candidate then has a keypoint at most of them.
    const cv::Mat mono = toMono8(image);
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(mono, corners, dense_corners_, 0.001, dense_min_distance_px_, cv::noArray(), 3, false);
    std::vector<KeyframeLandmark> pseudo;  // 2D only: the 3D position is not used for keypoints
    pseudo.reserve(corners.size());
    for (const cv::Point2f& c : corners) {
      KeyframeLandmark l;
      l.pixel = Eigen::Vector2d(c.x, c.y);
      pseudo.push_back(l);
    }
    appendReplicated(describePoints(mono, pseudo, dense_max_level_), dense_max_level_, features_.orb_scale_factor, camera_, &submap);
  }
  if (points != nullptr) *points = std::move(described);
  return submap;
}

DescribedPoints KeyframeDescriber::describePoints(const cv::Mat& image, const std::vector<KeyframeLandmark>& features) {
  return describePoints(image, features, std::numeric_limits<int>::max());
}

std::vector<cv::Point2f> KeyframeDescriber::cornersOnLevel(const std::vector<cv::Mat>& pyramid, int level,
                                                          int max_corners, double min_distance_px) const {
  std::vector<cv::Point2f> corners;
  if (level < 0 || level >= static_cast<int>(pyramid.size()) || max_corners <= 0) return corners;
  cv::goodFeaturesToTrack(pyramid[static_cast<size_t>(level)], corners, max_corners, 0.001, min_distance_px,
                          cv::noArray(), 3, false);
  // cv::ORB's convention for its own keypoints (level pixel x scale), so both kinds agree.
  const float scale = static_cast<float>(std::pow(features_.orb_scale_factor, level));
  for (cv::Point2f& c : corners) c *= scale;
  return corners;
}

DescribedPoints KeyframeDescriber::describeSeabedCorners(const cv::Mat& image, const DescribedPoints& tracked,
                                                         const Eigen::Isometry3d& T_odom_c, int max_corners,
                                                         double min_distance_px, int max_level) {
  DescribedPoints out;
  const cv::Mat mono = toMono8(image);
  if (mono.empty() || max_corners <= 0 || max_level < 1 || features_.descriptor != DescriptorType::kOrb) return out;
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
  if (pixel.size() < static_cast<size_t>(kNeighbours)) return out;
  const std::vector<cv::Mat> pyramid = buildPyramid(mono);
  uint64_t next_id = uint64_t{1} << 63;
  for (int level = 1; level <= max_level && level < static_cast<int>(pyramid.size()); ++level) {
    const int n = static_cast<int>(std::lround(max_corners / std::pow(features_.orb_scale_factor, 2.0 * (level - 1))));
    const std::vector<cv::Point2f> corners = cornersOnLevel(pyramid, level, n, min_distance_px);
    const std::vector<Eigen::Vector2d> normalized = undistortPixels(camera_, corners);
    std::vector<KeyframeLandmark> landmarks;
    std::vector<std::pair<double, size_t>> nearest(pixel.size());
    for (size_t c = 0; c < corners.size(); ++c) {
      const Eigen::Vector2d px(corners[c].x, corners[c].y);
      for (size_t i = 0; i < pixel.size(); ++i) nearest[i] = {(pixel[i] - px).squaredNorm(), i};
      std::partial_sort(nearest.begin(), nearest.begin() + kNeighbours, nearest.end());
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
    mergeDescribedPoints(&out, describePointsOnLevels(mono, landmarks, level, level));
  }
  return out;
}

DescribedPoints KeyframeDescriber::describePoints(const cv::Mat& image, const std::vector<KeyframeLandmark>& features,
                                                  int max_level) {
  return describePointsOnLevels(image, features, 0, max_level);
}

DescribedPoints KeyframeDescriber::describePointsOnLevels(const cv::Mat& image,
                                                          const std::vector<KeyframeLandmark>& features, int min_level,
                                                          int max_level) {
  DescribedPoints out;
  const cv::Mat mono = toMono8(image);
  if (mono.empty() || features.empty()) return out;

  // Points usable at all: finite, and (as cv::ORB requires) away from the level-0 border.
  std::vector<size_t> usable;
  for (size_t i = 0; i < features.size(); ++i) {
    const KeyframeLandmark& f = features[i];
    if (!f.p_odom.allFinite() || !f.pixel.allFinite()) continue;
    if (f.pixel.x() < kOrbEdgeThreshold || f.pixel.y() < kOrbEdgeThreshold ||
        f.pixel.x() >= mono.cols - kOrbEdgeThreshold || f.pixel.y() >= mono.rows - kOrbEdgeThreshold)
      continue;
    usable.push_back(i);
  }
  if (usable.empty()) return out;

  // One keypoint per (point, level), class_id = index into `owners` (cv::ORB may reorder and
  // drop keypoints; class_id survives).
  struct Owner {
    uint32_t point;
    int level;
  };
  std::vector<Owner> owners;
  std::vector<cv::KeyPoint> keypoints;
  for (size_t u = 0; u < usable.size(); ++u) {
    const KeyframeLandmark& f = features[usable[u]];
    out.feature_id.push_back(f.id);
    out.p_odom.push_back(f.p_odom);
    out.pixel.push_back(f.pixel);
  }

  if (features_.descriptor == DescriptorType::kOrb) {
    const std::vector<cv::Mat> pyramid = buildPyramid(mono);
    const int levels = static_cast<int>(std::min<size_t>(pyramid.size(), static_cast<size_t>(std::max(max_level, 0)) + 1));
    for (int level = std::max(min_level, 0); level < levels; ++level) {
      const double scale = std::pow(features_.orb_scale_factor, level);
      for (size_t u = 0; u < usable.size(); ++u) {
        const cv::Point2f pt0(static_cast<float>(out.pixel[u].x()), static_cast<float>(out.pixel[u].y()));
        const cv::Point2f pt_level(static_cast<float>(pt0.x / scale), static_cast<float>(pt0.y / scale));
        // Low Harris response on this level: the corner has blurred into an edge or a flat
        // patch here, and its descriptor would only add false matches.
        const double response = harrisResponse(pyramid[static_cast<size_t>(level)], pt_level, kHarrisBlock);
        if (response < harris_threshold_ || response <= 0.0) continue;
        const double angle = intensityCentroidAngleDeg(pyramid[static_cast<size_t>(level)], pt_level, kOrbHalfPatch);
        if (angle < 0.0) continue;
        cv::KeyPoint kp(pt0, static_cast<float>(kOrbPatchSize * scale), static_cast<float>(angle),
                        static_cast<float>(response), level, static_cast<int>(owners.size()));
        keypoints.push_back(kp);
        owners.push_back(Owner{static_cast<uint32_t>(u), level});
      }
    }
    if (keypoints.empty()) return out;
    cv::Mat descriptors;
    orb_->compute(mono, keypoints, descriptors);
    const std::vector<BinaryDescriptor> d = descriptorsFromMat(descriptors);
    if (d.size() != keypoints.size()) throw std::logic_error("KeyframeDescriber: ORB returned mismatched descriptors");
    for (size_t i = 0; i < keypoints.size(); ++i) {
      const Owner& o = owners.at(static_cast<size_t>(keypoints[i].class_id));
      out.descriptors.push_back(d[i]);
      out.point_of_descriptor.push_back(o.point);
      out.level_of_descriptor.push_back(o.level);
    }
  } else {
    // BRIEF is single scale and unoriented (the baseline): one descriptor per point.
    for (size_t u = 0; u < usable.size(); ++u) {
      const cv::Point2f pt(static_cast<float>(out.pixel[u].x()), static_cast<float>(out.pixel[u].y()));
      const double response = harrisResponse(mono, pt, kHarrisBlock);
      if (response < harris_threshold_ || response <= 0.0) continue;
      keypoints.emplace_back(pt, static_cast<float>(BriefDescriptor::kPatchSize), -1.0f, static_cast<float>(response),
                             0, static_cast<int>(owners.size()));
      owners.push_back(Owner{static_cast<uint32_t>(u), 0});
    }
    const std::vector<BinaryDescriptor> d = brief_.compute(mono, &keypoints);
    for (size_t i = 0; i < keypoints.size(); ++i) {
      const Owner& o = owners.at(static_cast<size_t>(keypoints[i].class_id));
      out.descriptors.push_back(d[i]);
      out.point_of_descriptor.push_back(o.point);
      out.level_of_descriptor.push_back(0);
    }
  }
  return out;
}

}  // namespace vims
