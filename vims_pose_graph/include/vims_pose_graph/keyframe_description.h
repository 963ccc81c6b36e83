#pragma once
/// @file keyframe_description.h
/// @brief What the loop closer keeps of a keyframe image (the visual submap: conventional ORB
/// corner selection) and how the VIO's tracked 3D points are described for 3D-2D matching
/// (the paper's corner replication across pyramid scales). docs/pose_graph.md, "Visual submaps".

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <vector>

#include "vims_common/keyframe_data.h"
#include "vims_common/sequence_config.h"
#include "vims_pose_graph/feature_extraction.h"
#include "vims_pose_graph/vocabulary.h"

namespace vims {

/// The visual submap of one keyframe: its image's keypoints (ORB: multi-scale, oriented,
/// strongest per level -- the conventional corner selection; BRIEF: single scale) with
/// descriptors, their undistorted normalised coordinates (for PnP), and the bag-of-words vector
/// of those keypoints. Optionally followed by the keyframe's own tracked corners, replicated
/// across scales like a query's (matching only, not in the BoW vector): a later query describes
/// its tracked corners, and the same detector on both sides re-finds the same corners (on the
/// simulated seabed ~40 % more correct matches than ORB keypoints alone). An image without
/// usable corners gives an empty submap (the keyframe is still a pose-graph node but never a
/// loop candidate).
struct VisualSubmap {
  std::vector<cv::KeyPoint> keypoints;        ///< distorted pixels; octave = pyramid level
  std::vector<BinaryDescriptor> descriptors;  ///< descriptors[i] of keypoints[i]
  std::vector<Eigen::Vector2d> normalized;    ///< undistorted (x/z, y/z) of keypoints[i]
  BowVector bow;                              ///< of the conventional (detected) keypoints

  bool empty() const { return keypoints.empty(); }
};

/// The tracked 3D points of a keyframe with their descriptors. ORB: one descriptor per pyramid
/// level where the replicated keypoint survived the Harris test (several per point);
/// BRIEF: one, at the original scale.
struct DescribedPoints {
  std::vector<uint64_t> feature_id;     ///< VIO track id per point
  std::vector<Eigen::Vector3d> p_odom;  ///< per point, VIO frame of the keyframe's session
  std::vector<Eigen::Vector2d> pixel;   ///< per point, distorted pixel in the keyframe image
  std::vector<BinaryDescriptor> descriptors;
  std::vector<uint32_t> point_of_descriptor;  ///< owning point of each descriptor
  std::vector<int> level_of_descriptor;       ///< pyramid level of each descriptor

  size_t numPoints() const { return p_odom.size(); }
  bool empty() const { return p_odom.empty(); }
};

/// Harris corner response of `image` (CV_8UC1) at `pt` over a block_size x block_size window of
/// 3x3 Sobel gradients, with cv::ORB's normalisation (gradients divided by 4 * block_size * 255),
/// so values compare directly with cv::ORB's HARRIS_SCORE keypoint responses. Returns 0 when the
/// window (plus the Sobel border) leaves the image.
double harrisResponse(const cv::Mat& image, const cv::Point2f& pt, int block_size = 7, double k = 0.04);

/// Orientation of the intensity centroid (Rosin 1999, as in ORB) of the disc of `radius`
/// around `pt` in degrees [0, 360), the convention of cv::KeyPoint::angle. Returns a negative
/// value when the disc leaves the image.
double intensityCentroidAngleDeg(const cv::Mat& image, const cv::Point2f& pt, int radius = 15);

/// Undistorts pixels to normalised coordinates with the sequence's camera model (CameraModel).
std::vector<Eigen::Vector2d> undistortPixels(const CameraCalibration& camera, const std::vector<cv::Point2f>& pixels);

/// The ORB pyramid of a mono8 image: level l = level l-1 resized by 1/scale_factor with
/// INTER_LINEAR_EXACT to round(size / scale_factor^l), the images cv::ORB builds; at most `levels`
/// levels, ending before one too small for ORB's 31 px patch.
std::vector<cv::Mat> buildOrbPyramid(const cv::Mat& mono, double scale_factor, int levels);

/// cv::goodFeaturesToTrack (no mask, minimum eigenvalue, 3x3 Sobel gradients) split into its two
/// halves, so that one response map serves several selections on the same image: the
/// constructor computes the response, zeroes it below quality_level x its maximum and keeps the
/// 3x3 local maxima; select() takes them strongest first (equal responses: later pixel first,
/// OpenCV's deterministic order) with OpenCV's greedy grid test. select(n, d) returns exactly
/// goodFeaturesToTrack(image, n, quality_level, d, noArray(), block_size, false) (test:
/// ShiTomasiCandidates.SelectionEqualsGoodFeaturesToTrack). Unlike OpenCV, which sorts all
/// candidates, it sorts them only as far as a selection reaches.
class ShiTomasiCandidates {
 public:
  ShiTomasiCandidates(const cv::Mat& mono, double quality_level, int block_size);

  /// At most max_corners (<= 0: all) candidates, strongest first, none closer than min_distance
  /// to a stronger selected one (min_distance < 1: no distance test), in pixels of the image.
  /// Not const: sorts more of the candidates when it needs them.
  std::vector<cv::Point2f> select(int max_corners, double min_distance);
  size_t size() const { return keys_.size(); }

 private:
  /// Makes keys_[0, n) (n capped at size()) the n strongest candidates in order.
  void sortFirst(size_t n);
  cv::Point pixelOf(size_t i) const;

  cv::Size image_size_;
  /// Local maxima above the quality threshold: response (order-preserving bits) << 32 | pixel
  /// index, so descending key order is OpenCV's order. [0, sorted_) is sorted descending and
  /// every later key is smaller than those.
  std::vector<uint64_t> keys_;
  size_t sorted_ = 0;
};

/// A keyframe image prepared once for all of its descriptions (the submap's tracked and dense
/// corners, the query's seabed corners): the mono8 image, its ORB pyramid and, per pyramid
/// level, the Shi-Tomasi candidates (detected on first use). The pyramid and the corner
/// responses were built once per describe call before, several times per keyframe
/// (docs/pose_graph.md, "Corner replication").
class KeyframeImage {
 public:
  /// mono8 or bgr8 `image` (an empty or unsupported image gives empty()); `levels` pyramid levels.
  KeyframeImage(const cv::Mat& image, double scale_factor, int levels);

  bool empty() const { return mono_.empty(); }
  const cv::Mat& mono() const { return mono_; }
  const std::vector<cv::Mat>& pyramid() const { return pyramid_; }

  /// Shi-Tomasi corners (block 3, 0.1 % quality: the tracker's detector) of pyramid level
  /// `level`, at most max_corners min_distance_px apart on that level, in level-0 pixels (level
  /// pixel x scale^level, cv::ORB's convention for its own keypoints). Equals
  /// cv::goodFeaturesToTrack on that level; the response is computed once per level.
  std::vector<cv::Point2f> cornersOnLevel(int level, int max_corners, double min_distance_px);

 private:
  cv::Mat mono_;
  std::vector<cv::Mat> pyramid_;
  double scale_factor_;
  std::vector<std::unique_ptr<ShiTomasiCandidates>> candidates_;  ///< per level, null until used
};

/// Everything the loop closer keeps of one keyframe (KeyframeDescriber::describeKeyframeAndSeabed).
struct KeyframeDescription {
  VisualSubmap submap;            ///< see describeKeyframe
  DescribedPoints points;         ///< its tracked points (the loop query's own points)
  DescribedPoints seabed_points;  ///< its seabed corners (see describeSeabedCorners); empty when off
};

/// Builds visual submaps and described points. Keeps OpenCV detector objects: one per thread.
class KeyframeDescriber {
 public:
  /// `features` must be the vocabulary's training settings (descriptor type included).
  /// `harris_threshold`: see LoopDetectorOptions::harris_threshold. Throws std::invalid_argument
  /// for invalid options.
  /// `include_tracked_corners`: see LoopDetectorOptions::submap_include_tracked_corners.
  KeyframeDescriber(const FeatureExtractionOptions& features, double harris_threshold, const CameraCalibration& camera,
                    bool include_tracked_corners = true);

  /// The visual submap of an image alone (detected keypoints; mono8, bgr8 is converted). An empty
  /// image or one without corners (black frame) gives an empty submap. `vocabulary` may be null
  /// (no BoW vector).
  VisualSubmap describeImage(const cv::Mat& image, const BinaryVocabulary* vocabulary);

  /// A keyframe: its visual submap (describeImage, plus the replicated tracked corners when
  /// enabled) and, in *points, its described tracked points for use as a loop query.
  VisualSubmap describeKeyframe(const cv::Mat& image, const std::vector<KeyframeLandmark>& features,
                                const BinaryVocabulary* vocabulary, DescribedPoints* points);

  /// describeKeyframe and, when set (setSeabedCorners) and the submap is not empty,
  /// describeSeabedCorners of the same keyframe (T_odom_c: its camera pose in the VIO frame), with
  /// the same results as the separate calls but one pyramid, one corner response per level and
  /// one cv::ORB::compute call (each builds and blurs ORB's own 8-level pyramid) for the
  /// keyframe (test: KeyframeDescriber.OnePassEqualsSeparateCalls).
  KeyframeDescription describeKeyframeAndSeabed(const cv::Mat& image, const std::vector<KeyframeLandmark>& features,
                                                const Eigen::Isometry3d& T_odom_c, const BinaryVocabulary* vocabulary);

  /// Describes the tracked points of a keyframe. ORB: each point is replicated on every pyramid
  /// level (same location, size patch_size * scale^level), oriented by the intensity centroid
  /// of that level, and dropped on levels where its Harris response is below the threshold or
  /// its patch leaves the image; BRIEF: one unoriented descriptor at the original scale (also
  /// Harris-tested). Points with non-finite coordinates are skipped.
  DescribedPoints describePoints(const cv::Mat& image, const std::vector<KeyframeLandmark>& features);
  /// The same on pyramid levels 0..max_level only.
  DescribedPoints describePoints(const cv::Mat& image, const std::vector<KeyframeLandmark>& features, int max_level);

  /// Dense corners of describeKeyframe's submap (see LoopDetectorOptions::submap_dense_corners);
  /// off (0) unless set. ORB only (BRIEF, the baseline, keeps its single-scale detected corners).
  void setDenseCorners(int max_corners, double min_distance_px, int max_level);
  /// Detect the dense corners on every pyramid level 0..max_level (up to max_corners / s^(2l)
  /// on level l, described on that level only) instead of on level 0 replicated to the levels
  /// above (LoopDetectorOptions::submap_dense_corners_per_level).
  void setDenseCornersPerLevel(bool per_level) { dense_per_level_ = per_level; }

  /// The query's seabed corners (LoopDetectorOptions::query_seabed_corners): Shi-Tomasi corners
  /// detected on pyramid levels 1..max_level of the keyframe image (up to max_corners on level 1,
  /// fewer by the area on the coarser ones, min_distance_px apart on their level), each
  /// described on its own level, with a 3D position from the VIO's tracked points: the inverse
  /// depth of the seabed is locally a plane in normalised coordinates (1/z = a x + b y + c for
  /// a plane), fitted to the kNeighbours tracked points nearest in the image and evaluated on
  /// the corner's ray. Corners whose fit is degenerate or whose depth leaves the neighbours'
  /// range by more than half of it are dropped. Feature ids have the top bit set (never a VIO
  /// track id). `tracked`: the keyframe's described points (p_odom), T_odom_c: its camera pose in
  /// the VIO frame. Empty with fewer than kNeighbours tracked points in front of the camera.
  DescribedPoints describeSeabedCorners(const cv::Mat& image, const DescribedPoints& tracked,
                                        const Eigen::Isometry3d& T_odom_c, int max_corners, double min_distance_px,
                                        int max_level);
  static constexpr int kNeighbours = 8;
  /// The seabed corners describeKeyframeAndSeabed adds (arguments of describeSeabedCorners);
  /// max_corners 0 (the default) = none.
  void setSeabedCorners(int max_corners, double min_distance_px, int max_level);

  const FeatureExtractionOptions& featureOptions() const { return features_; }

 private:
  class OrbBatch;

  /// The image prepared with this describer's pyramid (one level for BRIEF).
  KeyframeImage prepare(const cv::Mat& image) const;
  /// describeKeyframe(AndSeabed): seabed corners only with `T_odom_c` and setSeabedCorners.
  KeyframeDescription describeAll(KeyframeImage& image, const std::vector<KeyframeLandmark>& features,
                                  const Eigen::Isometry3d* T_odom_c, const BinaryVocabulary* vocabulary);
  /// The describable points of `features` (finite, outside ORB's border), without descriptors.
  static DescribedPoints usablePoints(const cv::Mat& mono, const std::vector<KeyframeLandmark>& features);
  /// Queues the ORB keypoints of `points` replicated on pyramid levels min_level..max_level
  /// (Harris-tested, oriented) into `batch`; their descriptors go to *points on batch.compute.
  void replicateOnLevels(const KeyframeImage& image, DescribedPoints* points, int min_level, int max_level,
                         OrbBatch* batch) const;
  /// BRIEF: one descriptor per Harris-tested point, at the original scale.
  void describeBrief(const cv::Mat& mono, DescribedPoints* points) const;
  /// Queues the seabed corners of levels 1..max_level into `batch` as entries of *per_level (one
  /// DescribedPoints per level; merged in level order after batch.compute).
  void queueSeabedCorners(KeyframeImage& image, const DescribedPoints& tracked, const Eigen::Isometry3d& T_odom_c,
                          int max_corners, double min_distance_px, int max_level,
                          std::vector<std::unique_ptr<DescribedPoints>>* per_level, OrbBatch* batch) const;

  FeatureExtractionOptions features_;
  double harris_threshold_;
  bool include_tracked_corners_;
  int dense_corners_ = 0;
  double dense_min_distance_px_ = 4.0;
  int dense_max_level_ = 3;
  bool dense_per_level_ = false;
  int seabed_corners_ = 0;
  double seabed_min_distance_px_ = 4.0;
  int seabed_max_level_ = 3;
  CameraCalibration camera_;
  FeatureExtractor extractor_;
  cv::Ptr<cv::ORB> orb_;  ///< computes descriptors at given keypoints (same settings as the extractor)
  BriefDescriptor brief_;
};

/// Adds the described points of an older keyframe of the same VIO session to `local` (a loop
/// query's local map): a point whose VIO track id is already in `local` keeps its position (the
/// newer estimate) and gains the older view's descriptors (several views of one point match a
/// revisit from more directions); other points are appended with their position and descriptors.
void mergeDescribedPoints(DescribedPoints* local, const DescribedPoints& older);

/// Converts KeyframeData.image to CV_8UC1 (mono8 as is, 3-channel BGR to grey); an empty or
/// unsupported image gives an empty matrix.
cv::Mat toMono8(const cv::Mat& image);

}  // namespace vims
