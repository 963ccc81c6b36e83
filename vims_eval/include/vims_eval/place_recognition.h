#pragma once
/// @file place_recognition.h
/// @brief Place recognition alone (the paper's precision-recall curves and recognition
/// matrices): every keyframe of a run is a query against every historical keyframe, each pair
/// is scored by four methods (Mag-ORB, Mag, ORB, BRIEF) and labelled true when the ground-truth
/// positions are within a radius. Definitions in docs/evaluation.md, "Place recognition".

#include <cstdint>
#include <opencv2/core.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "vims_pose_graph/loop_closing_options.h"

namespace vims {
namespace eval {

/// One point of a precision-recall curve: pairs with score >= threshold are "recognised".
struct PrPoint {
  double threshold = 0.0;
  double precision = 1.0;
  double recall = 0.0;
  std::size_t tp = 0;
  std::size_t fp = 0;
};

struct PrCurve {
  std::string method;
  std::size_t pairs = 0;      ///< scored pairs
  std::size_t positives = 0;  ///< true pairs
  /// Thresholds descending; every distinct finite score is a threshold, the stored curve keeps
  /// one point per 0.001 change of precision or recall (and the last one).
  std::vector<PrPoint> points;
  PrPoint best;  ///< the point of maximum F0.5 (threshold +inf, nothing recognised, if none)
  double best_f05 = 0.0;
};

/// F-beta of precision p and recall r: (1 + b^2) p r / (b^2 p + r); 0 when both are 0.
double fBeta(double precision, double recall, double beta);

/// The curve of `scores` (higher = more similar; -inf = never recognised) against `truth`
/// (same length, 1 = true pair): thresholds at each distinct finite score, descending.
/// Throws std::invalid_argument for different lengths.
PrCurve computePrCurve(const std::string& method, const std::vector<float>& scores, const std::vector<uint8_t>& truth);

/// Recognition outcome of one (query, historical) cell.
enum class PairOutcome : uint8_t {
  kExcluded = 0,
  kTrueNegative = 1,
  kFalseNegative = 2,
  kFalsePositive = 3,
  kTruePositive = 4
};

/// Outcome matrix (rows = historical index y, cols = query index x; CV_8UC1 of PairOutcome),
/// `num_keyframes` square, cells not in `pairs` kExcluded. A pair is recognised when its score
/// >= threshold.
cv::Mat outcomeMatrix(std::size_t num_keyframes, const std::vector<std::pair<uint32_t, uint32_t>>& pairs,
                      const std::vector<float>& scores, const std::vector<uint8_t>& truth, double threshold);

/// Renders an outcome matrix (x = query keyframe, y = historical keyframe, origin bottom left)
/// with axes and a legend; larger matrices are reduced by blocks, a block showing its most
/// important outcome (TP > FP > FN > TN). Writes the PNG.
void writeOutcomeMatrixPng(const cv::Mat& outcomes, const std::string& title, const std::string& png_path);

struct PlaceRecognitionOptions {
  double true_match_radius_m = 1.5;  ///< horizontal GT distance of a true pair (the revisit radius)
  double max_gt_gap_s = 0.5;         ///< GT interpolation limit at keyframe times
  /// Queries are never compared with keyframes this recent (the detector's exclude_recent_*):
  /// historical = at least exclude_recent_keyframes keyframes and exclude_recent_s seconds older.
  /// Magnetic gate and signature look-up: the detector's options (LoopDetectorOptions,
  /// MagneticSubmapOptions defaults = config/pose_graph.yaml).
  LoopDetectorOptions loop;
  MagneticSubmapOptions magnetic;
};

/// Options with the detector's thresholds from a vims_offline system configuration file (its
/// `pose_graph` section; defaults when the section is absent). Throws ConfigError.
PlaceRecognitionOptions placeRecognitionOptionsFromConfig(const std::string& system_config_path);

struct PlaceRecognitionInputs {
  std::string sequence_dir;    ///< ground truth
  std::string orb_map;         ///< map saved by a run with ORB descriptors (mode full)
  std::string brief_map;       ///< map saved by a run with BRIEF descriptors (mode vi_slam), same sequence
  std::string signatures_csv;  ///< mag_signatures.csv of the ORB run
  std::string package_root;    ///< for the committed vocabularies
};

struct PlaceRecognitionResult {
  std::size_t keyframes = 0;
  std::size_t queries_with_signature = 0;
  std::vector<PrCurve> curves;  ///< Mag-ORB, Mag, ORB, BRIEF
  std::vector<std::string> figures;
  std::vector<std::string> files;  ///< CSVs
};

/// Loads the inputs, scores every pair, writes OUT/pr_curves.png, OUT/pr_curves.csv,
/// OUT/pr_best_f05.csv and OUT/recognition_<method>.png, prints the best F0.5 per method.
PlaceRecognitionResult runPlaceRecognition(const PlaceRecognitionInputs& inputs, const PlaceRecognitionOptions& options,
                                           const std::string& out_dir, std::ostream& out);

}  // namespace eval
}  // namespace vims
