#pragma once
/// @file pose_graph_manager_core.h
/// @brief The work of PoseGraphManager, done inline: keyframes, magnetic signatures and the
/// geomagnetic field in; the multi-scale map, loop detection and acceptance, map save/load and
/// the outputs. Knows nothing about threads or locks: the facade (synchronous mode) or
/// PoseGraphThreadRunner (asynchronous mode) calls it with the map lock held, except
/// describe(), which reads no map state. Its SolveScheduler decides when and what to optimise.

#include <Eigen/Geometry>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "solve_scheduler.h"
#include "vims_common/keyframe_data.h"
#include "vims_common/log.h"
#include "vims_common/magnetic_signature.h"
#include "vims_common/sequence_config.h"
#include "vims_pose_graph/geomagnetic_gate.h"
#include "vims_pose_graph/keyframe_description.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_pose_graph/loop_detector.h"
#include "vims_pose_graph/magnetic_submap.h"
#include "vims_pose_graph/multiscale_map.h"
#include "vims_pose_graph/pose_graph_outputs.h"
#include "vims_pose_graph/vehicle_field.h"

namespace vims {

/// The low-passed geomagnetic field in the body frame [T] at time t (feedGeomagnetic).
struct GeomagneticMeasurement {
  double t;
  Eigen::Vector3d field_body;
};

class PoseGraphManagerCore {
 public:
  /// See PoseGraphManager::PoseGraphManager (the same checks and exceptions).
  PoseGraphManagerCore(const PoseGraphManagerOptions& options, const SequenceConfig& sequence,
                       std::shared_ptr<const BinaryVocabulary> vocabulary, LoggerPtr logger);
  PoseGraphManagerCore(const PoseGraphManagerCore&) = delete;
  PoseGraphManagerCore& operator=(const PoseGraphManagerCore&) = delete;

  /// By default an optimisation request solves inline (synchronous mode). The thread runner
  /// hands the requests to its optimiser thread instead (called with the map lock held).
  void handOptimisationRequestsTo(std::function<void(OptimisationTrigger)> handler);

  // ---- inputs
  /// The expensive part of a keyframe (ORB, BoW, replication): needs no map state, so it may run
  /// without the map lock, but from one thread only (the describer keeps OpenCV detector objects).
  /// Empty for a keyframe addKeyframe will drop (non-finite time or invalid pose).
  KeyframeDescription describe(const KeyframeData& keyframe);
  /// Whether a keyframe at time t should be described and queried
  /// (PoseGraphManagerOptions::localisation_query_interval_s, place_min_interval_s); needs the map lock.
  bool wantsQuery(double t) const;
  /// See PoseGraphManager::feedKeyframe; `description` from describe(keyframe), or none when
  /// wantsQuery said no (`queried` false: an odometry node only).
  void addKeyframe(const KeyframeData& keyframe, KeyframeDescription description, bool queried = true);
  void addSignature(const SignatureWindow& window);
  void addGeomagnetic(double t, const Eigen::Vector3d& field_body);
  /// End of data: processes every waiting keyframe and signature, closes the open magnetic
  /// submap, optimises.
  void finish();

  // ---- map files and modes (see PoseGraphManager)
  void loadMap(const std::string& path);
  void saveMap(const std::string& path) const;
  void setMapMode(MapMode mode);
  MapMode mapMode() const { return map_mode_; }
  RelocalisationStatus relocalisationStatus() const;

  // ---- outputs (see PoseGraphManager)
  std::vector<KeyframePose> keyframePoses(bool include_loaded) const;
  Eigen::Isometry3d T_map_odom() const;
  std::vector<LoopEdgeInfo> loopEdges() const;
  const std::vector<LoopAttempt>& loopAttempts() const { return attempts_; }
  std::vector<LoopAttempt> takeNewLoopAttempts();
  MapContents mapContents() const;
  PoseGraphManagerStats stats() const;
  const std::optional<DetectionResult>& lastDetection() const { return last_detection_; }
  const MultiScaleMap& map() const { return map_; }

  SolveScheduler& scheduler() { return scheduler_; }
  const SolveScheduler& scheduler() const { return scheduler_; }

 private:
  struct PendingKeyframe {
    PoseGraphNodeId node = 0;
    double t = 0.0;
    BowVector bow;
    DescribedPoints points;
    /// The query's own seabed corners (LoopDetectorOptions::query_seabed_corners): added to its
    /// query only, not to the local map of later queries.
    DescribedPoints seabed_points;
    bool has_visual = false;
  };
  struct StoredWindow {
    double t;
    int coil;
    bool valid;
    Eigen::Vector3d amplitude_enu;
  };
  /// Described points of a processed keyframe: part of the local map of the next queries.
  struct RecentPoints {
    PoseGraphNodeId node;
    uint32_t session;
    DescribedPoints points;
  };

  /// A geomagnetic sample given to the gate, as measured, with what correcting it again needs.
  struct MeasuredGeomagnetic {
    PoseGraphNodeId node = 0;
    uint32_t session = 0;
    double t = 0.0;
    Eigen::Vector3d field_b = Eigen::Vector3d::Zero();
    ForwardMotion motion;
    Eigen::Matrix3d R_odom_b = Eigen::Matrix3d::Identity();
  };

  /// Whether a keyframe about to become node `new_node` at world position p_w_b, joining the
  /// component of node `component_node`, would only repeat a visual submap already in the map
  /// (LoopDetectorOptions::redundant_submap_radius_m).
  bool submapIsRedundant(PoseGraphNodeId new_node, double t, const Eigen::Vector3d& p_w_b,
                         PoseGraphNodeId component_node) const;
  /// Processes pending keyframes whose magnetic data is complete, and places signatures.
  void processReady(bool flush);
  void processPending(PendingKeyframe& pending);  ///< consumes its BoW vector and points
  void placeSignatures(bool flush);
  void addMagneticDraft(const std::optional<MagneticSubmapDraft>& draft);
  /// Re-fits the VIO's drift from the loops (PoseGraphOptions::learn_odometry_drift); logs a change.
  void learnOdometryDrift(double t);
  void acceptLoop(const LoopAttempt& attempt);
  /// The VIO's forward motion at a node (VehicleFieldEstimator's regressors); nullopt for a
  /// session's first two nodes.
  std::optional<ForwardMotion> forwardMotionAt(PoseGraphNodeId id) const;
  void logVehicleField() const;
  /// Gives this run's yaw factors the vehicle's field of the current fit (before each solve).
  void recorrectYawFactors();
  /// Feeds a keyframe's geomagnetic sample to the vehicle-field fit and, corrected, to the gate.
  void gateGeomagnetic(PoseGraphNodeId node, const Eigen::Vector3d& field_b);
  /// The sample as the gate sees it: the vehicle's field of the current fit taken out, levelled.
  GeomagneticCandidate candidateOf(const MeasuredGeomagnetic& m) const;
  /// Turns the gate's verdicts into yaw factors (accepted) or counted, logged rejections.
  void applyGeomagneticVerdicts(const std::vector<GeomagneticVerdict>& verdicts);
  void pruneBuffers();
  /// Solves inline (see solveNow), or hands the request over (handOptimisationRequestsTo).
  void requestOptimisation(OptimisationTrigger trigger);

  PoseGraphManagerOptions options_;
  ModeSettings mode_;
  SequenceConfig sequence_;
  std::shared_ptr<const BinaryVocabulary> vocabulary_;
  LoggerPtr logger_;
  KeyframeDescriber describer_;  ///< used by one thread only (the caller, or the processing thread)
  HierarchicalLoopDetector detector_;

  MultiScaleMap map_;
  std::map<int, MagneticSubmapBuilder> magnetic_builders_;  ///< by coil (SignatureWindow::coil)
  GeomagneticGate geomagnetic_gate_;
  VehicleFieldEstimator vehicle_field_;                   ///< taken out of the geomagnetic samples before the gate
  std::vector<MeasuredGeomagnetic> geomagnetic_history_;  ///< every sample of this run given to the gate
  std::map<PoseGraphNodeId, size_t> gated_;               ///< awaiting a verdict: node -> history index
  /// This run's yaw factors: (index into the map's yaw measurements, history index).
  std::vector<std::pair<size_t, size_t>> run_yaw_factors_;
  /// The vehicle-field fit has been used at some point of the run (recorrectYawFactors has work).
  bool yaw_factors_may_hold_correction_ = false;
  bool map_loaded_ = false;
  std::string map_path_;  ///< the loaded file
  MapMode map_mode_ = MapMode::kMapping;
  std::optional<uint32_t> current_session_;  ///< map session of the run's active VIO session
  uint32_t current_vio_session_ = 0;
  std::vector<PoseGraphNodeId> run_nodes_;  ///< this run's keyframes in time order
  std::deque<PendingKeyframe> pending_;
  /// Described points of the last processed keyframes, newest last: the local map of the next
  /// query (LoopDetectorOptions::query_local_map_keyframes).
  std::deque<RecentPoints> recent_points_;
  std::deque<StoredWindow> windows_;                ///< recent signature windows (query lookup, coverage)
  std::deque<StoredWindow> unplaced_;               ///< windows waiting to be placed on the trajectory
  std::deque<GeomagneticMeasurement> geomagnetic_;  ///< recent geomagnetic samples
  double latest_signature_t_ = -1e300;
  double latest_geomagnetic_t_ = -1e300;
  double latest_keyframe_t_ = -1e300;
  double last_queried_keyframe_t_ = -1e300;
  std::vector<LoopAttempt> attempts_;  ///< not yet taken (takeNewLoopAttempts)
  std::optional<DetectionResult> last_detection_;
  PoseGraphManagerStats stats_;  ///< all but `optimisations` (the scheduler counts those)
  SolveScheduler scheduler_;     ///< after map_ and run_nodes_, which it refers to
  std::function<void(OptimisationTrigger)> optimisation_handler_;  ///< empty: solve inline
};

}  // namespace vims
