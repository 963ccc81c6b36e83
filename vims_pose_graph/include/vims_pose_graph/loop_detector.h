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
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "vims_common/camera_model.h"
#include "vims_common/log.h"
#include "vims_common/sequence_config.h"
#include "vims_pose_graph/keyframe_description.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_pose_graph/loop_measurement.h"
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
  /// The match keyframe belongs to a loaded map (another run, with its own clock): t_match is
  /// then that run's time.
  bool match_in_map = false;
  bool accepted = false;
  /// PnP relative pose (query body in the match body frame) once PnP succeeded, else identity.
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  /// PnP inliers from the PnP stage on; the number of 2NN matches at the matching stage; 0 before.
  int inliers = 0;
  double mag_distance = std::numeric_limits<double>::quiet_NaN();  ///< |s_q - s_i| [T]; NaN: no magnetic stage
  double bow_score = std::numeric_limits<double>::quiet_NaN();     ///< NaN: not scored
  LoopStage stage = LoopStage::kMagnetic;
  /// The candidate came from the pose graph's estimate (LoopDetectorOptions::proximity_candidates
  /// or track_map_candidates), not from the magnetic and BoW stages.
  bool proximity = false;
  /// Standard deviations of the loop's 4-DoF relative pose (p_li_j [m], yaw_i_j [rad]) from its
  /// inliers (refineLoopMeasurement); NaN when PnP did not succeed, the refinement is off or the
  /// geometry was degenerate.
  Eigen::Vector4d sigma = Eigen::Vector4d::Constant(std::numeric_limits<double>::quiet_NaN());
};

/// A keyframe asking for a loop.
struct LoopQuery {
  PoseGraphNodeId node = 0;  ///< the query keyframe (already in the map)
  double t = 0.0;
  Eigen::Isometry3d T_odom_b = Eigen::Isometry3d::Identity();
  BowVector bow;           ///< of the query image's visual submap
  DescribedPoints points;  ///< tracked 3D points (VIO frame of the query's session)
  /// The query keyframe's seabed corners (KeyframeDescriber::describeSeabedCorners), matched in
  /// addition to `points` against candidates seen from higher up
  /// (LoopDetectorOptions::query_seabed_min_level_shift).
  DescribedPoints seabed_points;
  /// The query's magnetic signatures (ENU amplitude, tesla) by coil: per coil the valid one
  /// nearest its time, when one is (LoopDetectorOptions::query_signature_max_dt_s).
  std::map<int, Eigen::Vector3d> signatures_enu;
  /// The run is localising in a loaded map it is joined to (PoseGraphManagerCore): the loaded
  /// keyframes nearest the query's position are verified from the graph's prediction too
  /// (LoopDetectorOptions::track_map_candidates).
  bool track_loaded_map = false;
};

/// Result of geometric verification of one candidate.
struct VerificationResult {
  LoopStage stage = LoopStage::kMatching;  ///< kAccepted when it passed
  int num_matches = 0;
  int num_inliers = 0;
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  bool has_pose = false;
  int covisibility_confirming_neighbours = 0;
  /// Angle between the candidate camera's gravity direction from the PnP pose and from its VIO
  /// attitude [deg] (NaN until computed; LoopDetectorOptions::pnp_max_tilt_error_deg).
  double tilt_error_deg = std::numeric_limits<double>::quiet_NaN();
  std::vector<std::pair<uint32_t, uint32_t>> inlier_matches;  ///< (query point, candidate keypoint)
  /// The known-vertical refinement of the PnP pose and its covariance (refineLoopMeasurement).
  std::optional<LoopMeasurement> refined;
};

/// One 2NN match.
struct PointMatch {
  uint32_t point = 0;     ///< query point
  uint32_t keypoint = 0;  ///< candidate keypoint
  int distance = 0;       ///< Hamming distance (best over the point's descriptors)
};

/// Which candidate keypoint octaves a query descriptor of pyramid level l is compared with:
/// |octave - (l + shift)| <= tolerance; a negative tolerance compares all levels.
struct LevelWindow {
  double shift = 0.0;
  double tolerance = -1.0;

  /// +-max_level_difference around the descriptor's own level (-1: all levels).
  static LevelWindow around(int max_level_difference) {
    return LevelWindow{0.0, max_level_difference < 0 ? -1.0 : static_cast<double>(max_level_difference)};
  }
  bool admits(int level, int octave) const {
    return tolerance < 0.0 || std::abs(static_cast<double>(octave - level) - shift) <= tolerance + 1e-9;
  }
};

/// The pyramid-level offset at which a feature seen at depth `depth_query` appears in an image
/// taken at depth `depth_candidate`: log(depth_query / depth_candidate) / log(scale_factor)
/// (a patch of 31 s^l px at depth d_q covers 31 s^l d_q / d_c px at depth d_c). NaN when a
/// depth is not positive or the scale factor is not above 1.
double altitudeLevelShift(double depth_query, double depth_candidate, double scale_factor);

/// Median depth (camera z) of the query's 3D points in the query camera (T_odom_b T_b_c); NaN
/// without a point in front of the camera.
double medianQueryDepth(const DescribedPoints& points, const Eigen::Isometry3d& T_odom_c);

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
/// The same with an explicit level window (LevelWindow::around(d) gives the overload above).
std::vector<PointMatch> matchPointsToKeypoints(const DescribedPoints& points, const VisualSubmap& candidate,
                                               double ratio, int max_distance, double duplicate_radius_px,
                                               const LevelWindow& levels);

/// Guided matching (search by projection, as ORB-SLAM's relocalisation widens a weak PnP
/// consensus): each query point is projected into the candidate image with T_c_odom (the
/// candidate camera from the query's VIO frame, e.g. a PnP pose) and matched with the keypoint
/// of least descriptor distance within radius_px of its projection, when that distance is within
/// max_distance and below ratio times the second best within the radius (the second taken among
/// keypoints farther than duplicate_radius_px from the best, as in matchPointsToKeypoints). A
/// keypoint claimed by several points keeps the closest. Points behind the camera or projecting
/// outside the image are skipped.
std::vector<PointMatch> matchPointsByProjection(const DescribedPoints& points, const VisualSubmap& candidate,
                                                const CameraModel& camera, const Eigen::Isometry3d& T_c_odom,
                                                double radius_px, double ratio, int max_distance,
                                                double duplicate_radius_px, const LevelWindow& levels);

/// Stateless verifier (matching, PnP, covisibility) against a map.
class LoopVerifier {
 public:
  /// `features`: the descriptor settings of the map (the pyramid scale factor predicts levels
  /// across altitudes, see LoopDetectorOptions::match_level_from_altitude; ORB only).
  LoopVerifier(const LoopDetectorOptions& options, const CameraCalibration& camera,
               const FeatureExtractionOptions& features = FeatureExtractionOptions());

  /// Verifies `query` against map keyframe `candidate` (which must have a visual submap).
  VerificationResult verify(const LoopQuery& query, const MultiScaleMap& map, PoseGraphNodeId candidate) const;

  /// Verifies `query` against `candidate` from the pose graph's prediction of their relative
  /// pose (both must be in one component; else rejected at matching): guided matching from the
  /// predicted pose (matchPointsByProjection), the pose levelled on those matches, then the
  /// inlier count and covisibility as in verify(). For tracking a loaded map while localising
  /// (LoopDetectorOptions::track_map_candidates), where appearance alone finds too few matches.
  VerificationResult verifyFromPrediction(const LoopQuery& query, const MultiScaleMap& map,
                                          PoseGraphNodeId candidate) const;

  const LoopDetectorOptions& options() const { return options_; }
  /// This run's camera extrinsic from now on: the VIO's online estimate (the calibration's until then).
  void setRunCameraExtrinsic(const Eigen::Isometry3d& T_b_c) { T_b_c_ = T_b_c; }
  /// The levels a query descriptor is compared with in `candidate` (and its covisibility
  /// neighbours): predicted from the two camera altitudes when match_level_from_altitude is on,
  /// the descriptor is ORB, and query and candidate share a connected component (comparable
  /// world heights) and the query has a depth; else +-match_max_level_difference.
  LevelWindow levelWindow(const LoopQuery& query, const MultiScaleMap& map, PoseGraphNodeId candidate) const;

 private:
  /// The camera extrinsic of a map keyframe: its loaded session's (another run's rig), or this
  /// run's.
  const Eigen::Isometry3d& extrinsicOf(const MultiScaleMap& map, PoseGraphNodeId node) const;
  /// The candidate camera's pose in the query's VIO frame (T_c_odom) from `matches`: the
  /// known-vertical consensus (R_odom_c: the candidate camera's VIO attitude), P3P RANSAC and LM
  /// on its inliers, when a consensus of min_inliers exists. *num_inliers: the consensus found.
  std::optional<Eigen::Isometry3d> pnpPose(const DescribedPoints& points, const std::vector<PointMatch>& matches,
                                           const VisualSubmap& sub, const Eigen::Matrix3d& R_odom_c, int min_inliers,
                                           int* num_inliers) const;
  /// LM refinement of the pose (rvec, tvec) on object-image pairs in normalised coordinates.
  std::optional<Eigen::Isometry3d> refinedPose(const std::vector<cv::Point3d>& object,
                                               const std::vector<cv::Point2d>& image, cv::Mat rvec, cv::Mat tvec) const;
  /// The matches within pnp_reprojection_px of their projections under T_c_odom.
  std::vector<std::pair<uint32_t, uint32_t>> inliersUnder(const DescribedPoints& points,
                                                          const std::vector<PointMatch>& matches,
                                                          const VisualSubmap& sub,
                                                          const Eigen::Isometry3d& T_c_odom) const;
  /// The pose with the query's and the candidate's roll and pitch those of their VIO attitudes
  /// (refineLoopMeasurement) fitted to the matches within the inlier threshold of T_c_odom;
  /// nothing when fewer than guided_min_inliers are or the fit fails.
  std::optional<Eigen::Isometry3d> levelledPose(const LoopQuery& query, const DescribedPoints& points,
                                                const VisualSubmap& sub, const MapNode& cand,
                                                const Eigen::Isometry3d& T_bm_cm, const Eigen::Isometry3d& T_c_odom,
                                                const std::vector<PointMatch>& matches) const;
  /// The guided search from the hypothesis T_c_odom (LoopDetectorOptions::guided_min_inliers):
  /// the hypothesis levelled on its inliers among *matches, then *matches becomes the guided
  /// matches and the levelled pose fitted to them is returned (nothing when the fit fails).
  std::optional<Eigen::Isometry3d> guidedPose(const LoopQuery& query, const DescribedPoints& points,
                                              const VisualSubmap& sub, const MapNode& cand,
                                              const Eigen::Isometry3d& T_bm_cm, const Eigen::Isometry3d& T_c_odom,
                                              const LevelWindow& levels, std::vector<PointMatch>* matches) const;
  /// The last stages of a verification from the candidate camera's pose T_cm_odomq and the
  /// matches it was found with: the inliers, their count against pnp_min_inliers, the loop's
  /// pose and refinement, and the covisibility check; sets *result's stage.
  /// `sub`: the candidate's submap, as the caller read it (a loaded map decodes it per call).
  void confirm(const LoopQuery& query, const MultiScaleMap& map, PoseGraphNodeId candidate, const VisualSubmap& sub,
               const DescribedPoints& points, const std::vector<PointMatch>& matches,
               const Eigen::Isometry3d& T_cm_odomq, const LevelWindow& levels, VerificationResult* result) const;
  /// Guided matching (matchPointsByProjection) with the options' radius, ratio and distances.
  std::vector<PointMatch> matchNear(const DescribedPoints& points, const VisualSubmap& sub,
                                    const Eigen::Isometry3d& T_c_odom, const LevelWindow& levels) const;
  /// levelledPose twice from T_c_odom on the same matches (nothing when a round fails).
  std::optional<Eigen::Isometry3d> levelledOnMatches(const LoopQuery& query, const DescribedPoints& points,
                                                     const VisualSubmap& sub, const MapNode& cand,
                                                     const Eigen::Isometry3d& T_bm_cm,
                                                     const Eigen::Isometry3d& T_c_odom,
                                                     const std::vector<PointMatch>& matches) const;
  double pnpThreshold() const { return options_.pnp_reprojection_px / (0.5 * (camera_.fx + camera_.fy)); }
  /// Checks the match's neighbours; returns the number of confirming neighbours.
  int covisibleNeighbours(const DescribedPoints& points, const MultiScaleMap& map, PoseGraphNodeId match,
                          const Eigen::Isometry3d& T_bm_odomq,
                          const std::vector<std::pair<uint32_t, uint32_t>>& inliers, const LevelWindow& levels) const;

  LoopDetectorOptions options_;
  CameraCalibration camera_;
  CameraModel camera_model_;  ///< built once: the consistency check projects every inlier
  FeatureExtractionOptions features_;
  Eigen::Isometry3d T_b_c_;  ///< this run's camera extrinsic (the YAML's, or the VIO's latest estimate)
};

/// What one detection did (for tests, diagnostics and rviz).
struct DetectionResult {
  std::vector<LoopAttempt> attempts;
  std::optional<LoopAttempt> accepted;  ///< the accepted attempt, if any
  bool magnetic_stage_used = false;     ///< the stage ran (mode on and the query has a signature)
  std::vector<std::pair<uint32_t, double>> magnetic_candidates;    ///< (submap id, distance [T])
  std::vector<PoseGraphNodeId> bow_pool;                           ///< keyframes BoW was allowed to score
  std::vector<std::pair<PoseGraphNodeId, double>> bow_candidates;  ///< verified, in order (node, score)
  /// Verified after the BoW candidates (LoopDetectorOptions::proximity_candidates), nearest first.
  std::vector<PoseGraphNodeId> proximity_candidates;
  /// Verified last, from the graph's prediction (LoopQuery::track_loaded_map), nearest first.
  std::vector<PoseGraphNodeId> tracking_candidates;
};

/// A magnetic submap that passed the magnetic stage's test.
struct MagneticStageMatch {
  double distance_tesla = 0.0;  ///< signatureDistance to the query's signature of its coil
  uint32_t submap = 0;
};
/// The magnetic stage's test (paper, hierarchical loop closing), per coil: each submap for which
/// `considered` holds and whose coil the query heard passes when its signature is within
/// mag_distance_relative * |s_i| + mag_distance_floor_tesla of the query's signature of that
/// coil; of each coil the nearest mag_max_candidates are kept. Returned nearest first.
/// `nearest` (optional) receives the nearest considered submap of a heard coil whether it passed
/// or not (nothing when there is none).
std::vector<MagneticStageMatch> magneticStageMatches(const std::map<int, Eigen::Vector3d>& query_signatures,
                                                     const std::vector<MagneticSubmap>& submaps,
                                                     const LoopDetectorOptions& options,
                                                     const std::function<bool(const MagneticSubmap&)>& considered,
                                                     std::optional<MagneticStageMatch>* nearest = nullptr);

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
                           const ModeSettings& mode, const CameraCalibration& camera, LoggerPtr logger = nullptr,
                           const FeatureExtractionOptions& features = FeatureExtractionOptions());

  /// Runs the hierarchy for `query` over `map`. Candidates are keyframes with a visual submap
  /// other than the query, not recent (see isRecent). A query without BoW vector or with fewer
  /// described points than pnp_min_inliers gives no attempt.
  DetectionResult detect(const LoopQuery& query, const MultiScaleMap& map) const;

  /// True for keyframes of the current run (not loaded) within exclude_recent_keyframes
  /// keyframes or exclude_recent_s seconds of the query (isRecentKeyframe).
  bool isRecent(const MultiScaleMap& map, PoseGraphNodeId query, PoseGraphNodeId candidate) const;
  /// Up to proximity_candidates keyframes with a visual submap, not recent, in the query's
  /// component, whose world position is within proximity_radius_m horizontally of the query's
  /// current world position, nearest first, except those in `exclude` (already verified).
  std::vector<PoseGraphNodeId> proximityCandidates(const LoopQuery& query, const MultiScaleMap& map,
                                                   const std::vector<PoseGraphNodeId>& exclude = {}) const;
  /// The same for tracking a loaded map: up to track_map_candidates keyframes of loaded sessions
  /// within proximity_radius_m of the query, nearest first, except those in `exclude`.
  std::vector<PoseGraphNodeId> trackingCandidates(const LoopQuery& query, const MultiScaleMap& map,
                                                  const std::vector<PoseGraphNodeId>& exclude) const;

  const LoopVerifier& verifier() const { return verifier_; }
  /// LoopVerifier::setRunCameraExtrinsic.
  void setRunCameraExtrinsic(const Eigen::Isometry3d& T_b_c) { verifier_.setRunCameraExtrinsic(T_b_c); }
  const ModeSettings& mode() const { return mode_; }

 private:
  /// Up to `count` keyframes with a visual submap in the query's component, not recent, within
  /// proximity_radius_m horizontally of the query, nearest first, for which `admit` holds.
  std::vector<PoseGraphNodeId> nearestCandidates(const LoopQuery& query, const MultiScaleMap& map, int count,
                                                 const std::function<bool(PoseGraphNodeId)>& admit) const;

  LoopDetectorOptions options_;
  MagneticSubmapOptions magnetic_options_;
  ModeSettings mode_;
  LoopVerifier verifier_;
  LoggerPtr logger_;
};

}  // namespace vims
