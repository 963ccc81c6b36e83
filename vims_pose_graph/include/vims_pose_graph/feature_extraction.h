#pragma once
/// @file feature_extraction.h
/// @brief Keypoints and 256-bit binary descriptors for place recognition: ORB (multi-scale,
/// oriented; what VIMS uses) and BRIEF (single scale, not oriented; the VINS-Mono style baseline
/// the paper compares against). Descriptors are computed only for place recognition, never for
/// tracking (the front end tracks Shi-Tomasi corners with optical flow).
///
/// BRIEF here is VIMS's own implementation (OpenCV 4.6 ships BRIEF only in contrib): 256 fixed
/// point-pair intensity comparisons on a Gaussian-smoothed 48x48 patch around FAST corners at the
/// original image scale, with NO orientation. That it is not rotation invariant is the point of
/// the baseline: a downward camera revisiting a place with another heading sees a rotated image.

#include <array>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <string>
#include <vector>

#include "vims_common/config_reader.h"
#include "vims_pose_graph/binary_descriptor.h"

namespace vims {

template <typename Options>
class OptionTable;

enum class DescriptorType { kOrb, kBrief };

/// "orb" / "brief".
std::string toString(DescriptorType type);
/// Parses "orb" / "brief"; throws std::invalid_argument naming the value otherwise.
DescriptorType descriptorTypeFromString(const std::string& name);

struct FeatureExtractionOptions {
  DescriptorType descriptor = DescriptorType::kOrb;
  int max_features = 500;         ///< strongest keypoints kept per image
  double orb_scale_factor = 1.2;  ///< ORB pyramid ratio between levels
  int orb_levels = 8;             ///< ORB pyramid levels (1 = single scale)
  /// FAST intensity threshold (ORB and BRIEF keypoints). 10, not the usual 20: underwater images
  /// are low-contrast, and 20 leaves ~80 corners per simulated seabed frame (10: ~330).
  int fast_threshold = 10;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<FeatureExtractionOptions>& optionTable();

  /// Keys: descriptor (orb|brief), max_features, orb_scale_factor, orb_levels, fast_threshold.
  /// Unknown keys and out-of-range values throw ConfigError naming the key.
  static FeatureExtractionOptions fromReader(const ConfigReader& reader);
  std::string toYaml() const;
};

/// Keypoints and their descriptors (descriptors[i] belongs to keypoints[i]).
struct ImageFeatures {
  std::vector<cv::KeyPoint> keypoints;
  std::vector<BinaryDescriptor> descriptors;
};

/// The BRIEF test pattern and descriptor computation (single scale, unoriented).
class BriefDescriptor {
 public:
  /// Side of the square patch the tests sample from [px].
  static constexpr int kPatchSize = 48;
  /// Keypoints closer than this to the image border get no descriptor.
  static constexpr int kBorder = kPatchSize / 2 + 1;

  /// Builds the 256 point pairs from `pattern_seed`. The pairs are drawn i.i.d. from an isotropic
  /// Gaussian with sigma = kPatchSize / 5 clipped to the patch (Calonder et al. 2010, G II),
  /// with a Box-Muller transform on std::mt19937 output, so the pattern is the same on every
  /// platform for a seed. Descriptors of different seeds are not comparable.
  explicit BriefDescriptor(uint32_t pattern_seed = 0x5eedu);

  /// Descriptors of `keypoints` in `image` (CV_8UC1). Keypoints within kBorder of the border are
  /// removed from `keypoints`, so on return both vectors correspond one to one. The keypoint
  /// angle and octave are ignored.
  std::vector<BinaryDescriptor> compute(const cv::Mat& image, std::vector<cv::KeyPoint>* keypoints) const;

 private:
  struct Test {
    int8_t x1, y1, x2, y2;
  };
  std::array<Test, 256> tests_;
};

/// Detects keypoints and computes descriptors of the configured type on mono8 images.
/// Keeps OpenCV's detector object, so reuse one extractor per thread.
class FeatureExtractor {
 public:
  /// Throws std::invalid_argument for invalid options.
  explicit FeatureExtractor(const FeatureExtractionOptions& options);

  /// `image` must be CV_8UC1 (else std::invalid_argument). Returns at most max_features features.
  ImageFeatures extract(const cv::Mat& image);

  const FeatureExtractionOptions& options() const { return options_; }

 private:
  FeatureExtractionOptions options_;
  cv::Ptr<cv::ORB> orb_;
  cv::Ptr<cv::FastFeatureDetector> fast_;
  BriefDescriptor brief_;
};

}  // namespace vims
