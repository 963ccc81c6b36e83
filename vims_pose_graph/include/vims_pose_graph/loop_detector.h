#pragma once
/// @file loop_detector.h
/// @brief Hierarchical place recognition and loop verification (paper, "Hierarchical Place
/// Recognition" and "Loop Closure Verification"):
///   1. magnetic: magnetic submaps whose signature is close to the query's (Euclidean);
///   2. bag of words among the visual submaps clustered under those candidates;
///   3. 3D-2D matching of the query's described tracked points with the candidate's keypoints
///      (2-nearest-neighbour ratio test);
///   4. PnP RANSAC with a minimum inlier count;
///   5. covisibility: the match's temporal neighbours must see the inliers where the PnP pose
///      and the VIO predict them.
/// A candidate that survives gives T_match_query. Every candidate verified (and, optionally, the
/// best one a prefilter rejected) produces a LoopAttempt (one row of loops.csv).
/// docs/pose_graph.md, "Loop closing".

#include <Eigen/Geometry>

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "vims_common/log.h"
#include "vims_common/sequence_config.h"
#include "vims_pose_graph/keyframe_description.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_pose_graph/multiscale_map.h"

namespace vims {

/// The stage a loop attempt ended at: the stage that rejected it, or kAccepted.
enum class LoopStage { kMagnetic, kBow, kMatching, kPnp, kCovisibility, kAccepted };
/// "magnetic" | "bow" | "matching" | "pnp" | "covisibility" | "accepted".
std::string toString(LoopStage stage);
LoopStage loopStageFromString(const std::string& name);

/// One loop verification attempt (a row of loops.csv).
struct LoopAttempt {
  double t_query = 0.0;
  double t_match = 0.0;
  PoseGraphNodeId query_node = 0;
  PoseGraphNodeId match_node = 0;
  bool accepted = false;
  /// PnP relative pose (query body in the match body frame) once PnP succeeded, else identity.
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  /// PnP inliers from the PnP stage on; the number of 2NN matches at the matching stage; 0 before.
  int inliers = 0;
  double mag_distance = std::numeric_limits<double>::quiet_NaN();  ///< |s_q - s_i| [T]; NaN: no magnetic stage
  double bow_score = std::numeric_limits<double>::quiet_NaN();     ///< NaN: not scored
  LoopStage stage = LoopStage::kMagnetic;
};

/// A keyframe asking for a loop.
struct LoopQuery {
  PoseGraphNodeId node = 0;  ///< the query keyframe (already in the map)
  double t = 0.0;
  Eigen::Isometry3d T_odom_b = Eigen::Isometry3d::Identity();
  BowVector bow;             ///< of the query image's visual submap
  DescribedPoints points;    ///< tracked 3D points (VIO frame of the query's session)
  /// The query's magnetic signature (ENU amplitude, tesla) when a valid one is near its time.
  std::optional<Eigen::Vector3d> signature_enu;
};

/// Result of geometric verification of one candidate.
struct VerificationResult {
  LoopStage stage = LoopStage::kMatching;  ///< kAccepted when it passed
  int num_matches = 0;
  int num_inliers = 0;
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  bool has_pose = false;
  int covisibility_confirming_neighbours = 0;
  std::vector<std::pair<uint32_t, uint32_t>> inlier_matches;  ///< (query point, candidate keypoint)
};

/// One 2NN match.
struct PointMatch {
  uint32_t point = 0;     ///< query point
  uint32_t keypoint = 0;  ///< candidate keypoint
  int distance = 0;       ///< Hamming distance (best over the point's descriptors)
};

/// 3D-2D descriptor matching with the 2-nearest-neighbour ratio test: for each query point, the
/// best candidate keypoint (distance = minimum over the point's replicated descriptors whose
/// level is within max_level_difference of the keypoint's octave; -1: any level) is kept when it
/// is within max_distance and best < ratio * second best, the second best taken among keypoints
/// farther than duplicate_radius_px from the best (ORB finds one corner on several levels). A
/// keypoint claimed by several points keeps the closest one. ratio = 1 disables the ratio test
/// (for tests that show it matters).
std::vector<PointMatch> matchPointsToKeypoints(const DescribedPoints& points, const VisualSubmap& candidate,
                                               double ratio, int max_distance, double duplicate_radius_px,
                                               int max_level_difference = -1);

/// Stateless verifier (matching, PnP, covisibility) against a map.
class LoopVerifier {
 public:
  LoopVerifier(const LoopDetectorOptions& options, const CameraCalibration& camera);

  /// Verifies `query` against map keyframe `candidate` (which must have a visual submap).
  VerificationResult verify(const LoopQuery& query, const MultiScaleMap& map, PoseGraphNodeId candidate) const;

  const LoopDetectorOptions& options() const { return options_; }

 private:
  /// Checks the match's neighbours; returns the number of confirming neighbours.
  int covisibleNeighbours(const LoopQuery& query, const MultiScaleMap& map, PoseGraphNodeId match,
                          const Eigen::Isometry3d& T_bm_odomq,
                          const std::vector<std::pair<uint32_t, uint32_t>>& inliers) const;

  LoopDetectorOptions options_;
  CameraCalibration camera_;
  Eigen::Isometry3d T_b_c_;
  Eigen::Isometry3d T_c_b_;
};

/// What one detection did (for tests, diagnostics and rviz).
struct DetectionResult {
  std::vector<LoopAttempt> attempts;
  std::optional<LoopAttempt> accepted;  ///< the accepted attempt, if any
  bool magnetic_stage_used = false;     ///< the stage ran (mode on and the query has a signature)
  std::vector<std::pair<uint32_t, double>> magnetic_candidates;  ///< (submap id, distance [T])
  std::vector<PoseGraphNodeId> bow_pool;                         ///< keyframes BoW was allowed to score
  std::vector<std::pair<PoseGraphNodeId, double>> bow_candidates; ///< verified, in order (node, score)
};

/// The loop candidates' exclusion: true when `candidate` is a keyframe of the current run (not
/// loaded) that is not older than a query keyframe with id `query` at time `t_query`, or within
/// options.exclude_recent_keyframes keyframes or exclude_recent_s seconds of it. The query need
/// not be in the map yet (PoseGraphManager asks before adding a keyframe).
bool isRecentKeyframe(const LoopDetectorOptions& options, const MultiScaleMap& map, PoseGraphNodeId query,
                      double t_query, PoseGraphNodeId candidate);

class HierarchicalLoopDetector {
 public:
  /// Throws std::invalid_argument for invalid options.
  HierarchicalLoopDetector(const LoopDetectorOptions& options, const MagneticSubmapOptions& magnetic_options,
                           const ModeSettings& mode, const CameraCalibration& camera, LoggerPtr logger = nullptr);

  /// Runs the hierarchy for `query` over `map`. Candidates are keyframes with a visual submap
  /// other than the query, not recent (see isRecent). A query without BoW vector or with fewer
  /// described points than pnp_min_inliers gives no attempt.
  DetectionResult detect(const LoopQuery& query, const MultiScaleMap& map) const;

  /// True for keyframes of the current run (not loaded) within exclude_recent_keyframes
  /// keyframes or exclude_recent_s seconds of the query (isRecentKeyframe).
  bool isRecent(const MultiScaleMap& map, PoseGraphNodeId query, PoseGraphNodeId candidate) const;

  const LoopVerifier& verifier() const { return verifier_; }
  const ModeSettings& mode() const { return mode_; }

 private:
  LoopDetectorOptions options_;
  MagneticSubmapOptions magnetic_options_;
  ModeSettings mode_;
  LoopVerifier verifier_;
  LoggerPtr logger_;
};

}  // namespace vims
