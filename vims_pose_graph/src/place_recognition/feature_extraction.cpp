#include "vims_pose_graph/feature_extraction.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <stdexcept>

#include "vims_common/option_table.h"

namespace vims {

std::string toString(DescriptorType type) { return type == DescriptorType::kOrb ? "orb" : "brief"; }

DescriptorType descriptorTypeFromString(const std::string& name) {
  if (name == "orb") return DescriptorType::kOrb;
  if (name == "brief") return DescriptorType::kBrief;
  throw std::invalid_argument("unknown descriptor type '" + name + "' (expected orb or brief)");
}

const OptionTable<FeatureExtractionOptions>& FeatureExtractionOptions::optionTable() {
  using O = FeatureExtractionOptions;
  static const auto table =
      OptionTable<O>()
          .choice<DescriptorType>("descriptor", &O::descriptor, {DescriptorType::kOrb, DescriptorType::kBrief},
                                  [](DescriptorType type) { return toString(type); })
          .integer("max_features", &O::max_features, Bounds::closed(1, 100000))
          .number("orb_scale_factor", &O::orb_scale_factor, Bounds::closed(1.01, 2.0))
          .integer("orb_levels", &O::orb_levels, Bounds::closed(1, 16))
          .integer("fast_threshold", &O::fast_threshold, Bounds::closed(1, 254));
  return table;
}

FeatureExtractionOptions FeatureExtractionOptions::fromReader(const ConfigReader& reader) {
  return readOptions<FeatureExtractionOptions>(reader);
}

std::string FeatureExtractionOptions::toYaml() const { return optionTable().toYaml(*this); }

// ---------------------------------------------------------------------------------------------
// BRIEF
// ---------------------------------------------------------------------------------------------

BriefDescriptor::BriefDescriptor(uint32_t pattern_seed) {
  std::mt19937 engine(pattern_seed);
  const double sigma = kPatchSize / 5.0;
  const int half = kPatchSize / 2 - 1;
  auto uniform01 = [&]() { return (static_cast<double>(engine()) + 0.5) / 4294967296.0; };
  auto gaussianCoordinate = [&]() {
    // Box-Muller; resample values outside the patch instead of clipping them to its edge, so
    // the border pixels are not over-represented.
    for (;;) {
      const double v = sigma * std::sqrt(-2.0 * std::log(uniform01())) * std::cos(2.0 * M_PI * uniform01());
      const long r = std::lround(v);
      if (r >= -half && r <= half) return static_cast<int8_t>(r);
    }
  };
  for (Test& t : tests_) {
    do {
      t.x1 = gaussianCoordinate();
      t.y1 = gaussianCoordinate();
      t.x2 = gaussianCoordinate();
      t.y2 = gaussianCoordinate();
    } while (t.x1 == t.x2 && t.y1 == t.y2);  // a pixel compared with itself carries no bit
  }
}

std::vector<BinaryDescriptor> BriefDescriptor::compute(const cv::Mat& image,
                                                       std::vector<cv::KeyPoint>* keypoints) const {
  if (image.type() != CV_8UC1) throw std::invalid_argument("BriefDescriptor::compute: image must be CV_8UC1");
  // Smoothing makes single-pixel comparisons robust to noise (Calonder et al.: 9x9, sigma 2).
  cv::Mat smooth;
  cv::GaussianBlur(image, smooth, cv::Size(9, 9), 2.0, 2.0, cv::BORDER_REFLECT_101);
  std::vector<cv::KeyPoint> kept;
  std::vector<BinaryDescriptor> out;
  kept.reserve(keypoints->size());
  out.reserve(keypoints->size());
  for (const cv::KeyPoint& kp : *keypoints) {
    const int u = static_cast<int>(std::lround(kp.pt.x));
    const int v = static_cast<int>(std::lround(kp.pt.y));
    if (u < kBorder || v < kBorder || u >= image.cols - kBorder || v >= image.rows - kBorder) continue;
    BinaryDescriptor d;
    for (int i = 0; i < 256; ++i) {
      const Test& t = tests_[static_cast<size_t>(i)];
      if (smooth.at<uint8_t>(v + t.y1, u + t.x1) < smooth.at<uint8_t>(v + t.y2, u + t.x2)) d.setBit(i);
    }
    kept.push_back(kp);
    out.push_back(d);
  }
  keypoints->swap(kept);
  return out;
}

// ---------------------------------------------------------------------------------------------
// FeatureExtractor
// ---------------------------------------------------------------------------------------------

FeatureExtractor::FeatureExtractor(const FeatureExtractionOptions& options) : options_(options) {
  if (options_.max_features < 1 || options_.orb_levels < 1 || options_.orb_scale_factor <= 1.0 ||
      options_.fast_threshold < 1)
    throw std::invalid_argument("FeatureExtractor: invalid options");
  // ORB as in the paper's visual submaps: conventional per-level corner selection (Harris score),
  // 31x31 oriented patches, the standard 256-bit rBRIEF test set.
  orb_ = cv::ORB::create(options_.max_features, static_cast<float>(options_.orb_scale_factor), options_.orb_levels, 31,
                         0, 2, cv::ORB::HARRIS_SCORE, 31, options_.fast_threshold);
  fast_ = cv::FastFeatureDetector::create(options_.fast_threshold, true);
}

ImageFeatures FeatureExtractor::extract(const cv::Mat& image) {
  if (image.empty() || image.type() != CV_8UC1)
    throw std::invalid_argument("FeatureExtractor::extract: expected a non-empty CV_8UC1 image");
  ImageFeatures f;
  if (options_.descriptor == DescriptorType::kOrb) {
    cv::Mat desc;
    orb_->detectAndCompute(image, cv::noArray(), f.keypoints, desc);
    f.descriptors = descriptorsFromMat(desc);
  } else {
    fast_->detect(image, f.keypoints);
    // Drop border keypoints before ranking, so the strongest max_features all get descriptors.
    cv::KeyPointsFilter::runByImageBorder(f.keypoints, image.size(), BriefDescriptor::kBorder + 1);
    // Strongest first; a stable sort keeps the detector's order among equal responses, so the
    // kept set is deterministic (KeyPointsFilter::retainBest may keep extra ties).
    std::stable_sort(f.keypoints.begin(), f.keypoints.end(),
                     [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
    if (f.keypoints.size() > static_cast<size_t>(options_.max_features))
      f.keypoints.resize(static_cast<size_t>(options_.max_features));
    f.descriptors = brief_.compute(image, &f.keypoints);
  }
  return f;
}

}  // namespace vims
