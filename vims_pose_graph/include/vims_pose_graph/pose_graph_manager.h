#pragma once
/// @file pose_graph_manager.h
/// @brief The ROS-free core of the global pose graph node and of the offline runner (issue 5):
/// keyframes, magnetic signatures and the low-passed geomagnetic field in; the multi-scale
/// visual-magnetic map, hierarchical loop closing, 4-DoF optimisation, map save/load and
/// relocalisation inside; world poses, map -> odom, loop edges, loop attempts and map contents
/// out. docs/pose_graph.md, "PoseGraphManager".
///
/// Threading. `synchronous = true`: every feed call does its work inline (describe, detect,
/// optimise after each accepted loop and every N keyframes) -- deterministic, for the offline
/// runner and tests. `synchronous = false`: feed calls only enqueue; a processing thread
/// describes keyframes and detects loops, an optimiser thread runs PoseGraph4Dof::solve on a
/// snapshot without holding the map lock, so neither feeding nor reading outputs waits for a
/// solve. Output methods are thread-safe in both modes; in synchronous mode the feed methods
/// must be called from one thread (they use the keyframe describer outside the lock).

#include <Eigen/Geometry>

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "vims_common/keyframe_data.h"
#include "vims_common/log.h"
#include "vims_common/sequence_config.h"
#include "vims_magnetometer/signature_extractor.h"
#include "vims_pose_graph/input_recording.h"
#include "vims_pose_graph/keyframe_description.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_pose_graph/loop_detector.h"
#include "vims_pose_graph/magnetic_submap.h"
#include "vims_pose_graph/multiscale_map.h"

namespace vims {

/// An optimised keyframe pose (a line of global.tum).
struct KeyframePose {
  PoseGraphNodeId node = 0;
  double t = 0.0;
  uint32_t vio_session = 0;
  bool loaded = false;  ///< from a loaded map (another run)
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
};

struct LoopEdgeInfo {
  LoopEdgeId id = 0;
  PoseGraphNodeId match = 0;
  PoseGraphNodeId query = 0;
  double t_match = 0.0;
  double t_query = 0.0;
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  Eigen::Vector3d p_w_match = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_w_query = Eigen::Vector3d::Zero();
  bool enabled = true;
};

/// Map contents for visualisation (rviz markers).
struct VisualSubmapMarker {
  PoseGraphNodeId node = 0;
  double t = 0.0;
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();
  size_t num_keypoints = 0;
  bool loaded = false;
};
struct MagneticSubmapMarker {
  uint32_t id = 0;
  PoseGraphNodeId tied_node = 0;
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();  ///< the tied keyframe's optimised position
  double radius_m = 0.0;
  Eigen::Vector3d signature_enu = Eigen::Vector3d::Zero();  ///< [T]
  std::vector<PoseGraphNodeId> clustered;  ///< visual submaps within radius + cluster margin
};
struct MapContents {
  std::vector<VisualSubmapMarker> visual;
  std::vector<MagneticSubmapMarker> magnetic;
};

struct PoseGraphManagerStats {
  size_t keyframes = 0;           ///< accepted into the graph (this run)
  size_t keyframes_rejected = 0;  ///< non-finite pose, time not increasing
  size_t empty_keyframes = 0;     ///< no visual submap (no image / no corners)
  /// Keyframes whose visual submap was not stored: an older one of the same place already is
  /// (LoopDetectorOptions::redundant_submap_radius_m); they still ran their loop query.
  size_t culled_submaps = 0;
  size_t loaded_keyframes = 0;
  size_t sessions = 0;            ///< of this run
  size_t loop_queries = 0;
  size_t loop_attempts = 0;
  size_t loops_accepted = 0;
  size_t yaw_factors = 0;
  size_t magnetic_submaps = 0;
  size_t optimisations = 0;
  bool relocalised = false;
};

/// Why the manager optimised. kDeferredLoops: the solve from the earliest node of the loops that
/// local loop solves corrected (PoseGraphOptions::loop_local_solve_max_sigmas).
enum class OptimisationTrigger { kLoop, kPeriodic, kDeferredLoops, kFinish };
std::string toString(OptimisationTrigger trigger);

/// One solve of one component (benchmarks, replay; docs/pose_graph.md, "Cost of the optimisation").
struct OptimisationRecord {
  OptimisationTrigger trigger = OptimisationTrigger::kPeriodic;
  double t_keyframe = 0.0;    ///< time of the newest keyframe when it ran
  double solve_ms = 0.0;      ///< PoseGraph4Dof::solve, wall clock
  double solve_cpu_ms = 0.0;  ///< its CPU time on the calling thread (Ceres runs num_threads = 1 by default)
  /// After new loops: the largest whitened residual [sigmas] of those loops at the poses the
  /// solve started from, and whether it was a local loop solve (see PoseGraphOptions).
  double max_new_loop_sigmas = 0.0;
  bool local_loop_solve = false;
  PoseGraphReport report;     ///< without loop residuals
};

/// Timing of the optimisations so far.
struct PoseGraphTimings {
  std::vector<OptimisationRecord> solves;
  /// Per accepted loop: wall time from its acceptance to the applied result of the first
  /// optimisation that included it [ms] (the loop correction latency).
  std::vector<double> loop_correction_ms;
  /// The same in CPU time of the thread that accepted the loop and solved [ms]: synchronous mode
  /// only (empty otherwise), where it is not inflated by other jobs on the machine.
  std::vector<double> loop_correction_cpu_ms;
};

class PoseGraphManager {
 public:
  /// `vocabulary` must match the mode's descriptor (vocabularyPath(); see loadVocabulary).
  /// The sequence gives the camera (intrinsics, distortion, T_b_c) and the magnetometer
  /// declination. Throws std::invalid_argument for invalid options or a vocabulary of the wrong
  /// descriptor type. Starts the worker threads unless synchronous.
  PoseGraphManager(const PoseGraphManagerOptions& options, const SequenceConfig& sequence,
                   std::shared_ptr<const BinaryVocabulary> vocabulary, LoggerPtr logger = nullptr);
  /// Stops the worker threads (pending work is dropped; call finish() first to keep it).
  ~PoseGraphManager();
  PoseGraphManager(const PoseGraphManager&) = delete;
  PoseGraphManager& operator=(const PoseGraphManager&) = delete;

  /// Loads the vocabulary of the options' mode, resolving a relative path against package_root.
  /// Throws VocabularyFileError.
  static std::shared_ptr<const BinaryVocabulary> loadVocabulary(const PoseGraphManagerOptions& options,
                                                                const std::string& package_root);

  // ---- teach and repeat
  /// Loads a saved map; must be called before the first keyframe (std::logic_error otherwise).
  /// New keyframes are then matched against it; the first accepted loop to it moves the run
  /// into the map's frame. Throws MapFileError (clear message, manager unchanged).
  void loadMap(const std::string& path);
  /// Saves the map (waits for pending work in asynchronous mode; call finish() first to include
  /// the last keyframes and the open magnetic submap). Throws std::runtime_error on I/O errors.
  void saveMap(const std::string& path) const;

  // ---- inputs
  /// A keyframe from the VIO. Defined behaviour for bad input: a non-finite or non-rotation pose,
  /// or a time not after the previous keyframe's, is dropped with a warning; an empty or black
  /// image (or one without corners) gives a node without visual submap (never a loop query or
  /// candidate); a change of KeyframeData::session starts a new chain (docs: "Sessions").
  void feedKeyframe(const KeyframeData& keyframe);
  /// A magnetic signature window (only t, amplitude_enu and valid are used).
  void feedSignature(const SignatureWindow& window);
  /// The low-passed geomagnetic field in the body frame [T] (the magnetometer core already
  /// applied R_b_m); becomes a yaw factor of the nearest keyframe. Ignored in no_geom/vi_slam.
  void feedGeomagnetic(double t, const Eigen::Vector3d& field_body);
  /// End of data: processes every waiting keyframe and signature, closes the open magnetic
  /// submap, optimises; returns when done (also in asynchronous mode).
  void finish();
  /// Asynchronous mode: blocks until the queue is empty and no solve is running (no-op when synchronous).
  void waitForIdle() const;

  // ---- outputs (consistent snapshots; thread-safe)
  /// Optimised world poses of the keyframes (this run's only, unless include_loaded), in order.
  std::vector<KeyframePose> keyframePoses(bool include_loaded = false) const;
  /// map -> odom of the current VIO session (identity before the first keyframe).
  Eigen::Isometry3d T_map_odom() const;
  /// T_map_odom() * T_odom_b: the corrected current pose.
  Eigen::Isometry3d correctedPose(const Eigen::Isometry3d& T_odom_b) const;
  std::vector<LoopEdgeInfo> loopEdges() const;
  /// The loop attempts not yet taken (all of them if takeNewLoopAttempts() was never called).
  std::vector<LoopAttempt> loopAttempts() const;
  /// Hands over the attempts since the previous call and forgets them, so that a long run that
  /// streams loops.csv (vims_offline, the node) does not hold every attempt of the mission.
  std::vector<LoopAttempt> takeNewLoopAttempts();
  MapContents mapContents() const;
  PoseGraphManagerStats stats() const;
  /// The solves from index `first_solve` on (0: all) and every loop correction latency so far.
  PoseGraphTimings timings(size_t first_solve = 0) const;
  /// The detection of the most recent query keyframe (diagnostics, tests).
  std::optional<DetectionResult> lastDetection() const;
  /// Runs `f` on the map under the lock (tests, tools). `f` must not call back into the manager.
  void inspectMap(const std::function<void(const MultiScaleMap&)>& f) const;

  const PoseGraphManagerOptions& options() const { return options_; }
  const ModeSettings& mode() const { return mode_; }

 private:
  struct GeomagneticEvent {
    double t;
    Eigen::Vector3d field_body;
  };
  struct FinishEvent {};
  using Event = std::variant<KeyframeData, SignatureWindow, GeomagneticEvent, FinishEvent>;

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
    bool valid;
    Eigen::Vector3d amplitude_enu;
  };

  // Handlers (state lock held).
  void handleKeyframe(const KeyframeData& keyframe, VisualSubmap submap, DescribedPoints points,
                      DescribedPoints seabed_points);
  /// Whether a keyframe about to become node `new_node` at world position p_w_b, joining the
  /// component of node `component_node`, would only repeat a visual submap already in the map
  /// (LoopDetectorOptions::redundant_submap_radius_m).
  bool submapIsRedundant(PoseGraphNodeId new_node, double t, const Eigen::Vector3d& p_w_b,
                         PoseGraphNodeId component_node) const;
  void handleSignature(const SignatureWindow& window);
  void handleGeomagnetic(double t, const Eigen::Vector3d& field_body);
  void handleFinish();
  /// Processes pending keyframes whose magnetic data is complete, and places signatures.
  void processReady(bool flush);
  void processPending(PendingKeyframe& pending);  ///< consumes its BoW vector and points
  void placeSignatures(bool flush);
  void addMagneticDraft(const std::optional<MagneticSubmapDraft>& draft);
  void acceptLoop(const LoopAttempt& attempt);
  void pruneBuffers();
  /// Synchronous: solves the reference component and, if different, the current run's
  /// component now. Asynchronous: wakes the optimiser thread (requests during a solve merge).
  void requestOptimisation(OptimisationTrigger trigger);
  /// One solve: snapshots of the components to optimise and which waiting loops it covers.
  struct SolvePlan {
    std::vector<ComponentSnapshot> snapshots;
    size_t loops_included = 0;     ///< the first this many of loops_awaiting_correction_
    bool local = false;            ///< a local loop solve: those loops then await the deferred solve
    size_t deferred_included = 0;  ///< the first this many of loops_awaiting_deferred_solve_
    double max_new_loop_sigmas = 0.0;
  };
  /// Whether the loops corrected by local loop solves are due for their deferred solve.
  bool deferredSolveDue() const;
  /// Snapshots of the components to optimise (reference component, and the run's if separate),
  /// with the part to optimise for this trigger and state (docs/pose_graph.md, "Cost of the
  /// optimisation", "Local loop solves").
  SolvePlan planSolve(OptimisationTrigger trigger) const;
  /// Solves the snapshots and records their timing (no lock needed).
  std::vector<PoseGraphSolution> solveSnapshots(const std::vector<ComponentSnapshot>& snapshots,
                                                OptimisationTrigger trigger, double t_keyframe,
                                                std::vector<OptimisationRecord>* records) const;
  /// Applies solutions and records the loop correction latency of the loops they include.
  void applySolutions(const SolvePlan& plan, const std::vector<PoseGraphSolution>& solutions,
                      std::vector<OptimisationRecord> records);

  // Threads.
  void processingLoop();
  void optimiserLoop();
  void enqueue(Event event);
  void dispatch(Event& event);

  PoseGraphManagerOptions options_;
  ModeSettings mode_;
  SequenceConfig sequence_;
  std::shared_ptr<const BinaryVocabulary> vocabulary_;
  LoggerPtr logger_;
  std::unique_ptr<InputRecorder> recorder_;  ///< options_.record_inputs_path; written by the feed calls
  std::mutex recorder_mutex_;
  KeyframeDescriber describer_;  ///< used by one thread only (the caller, or the processing thread)
  HierarchicalLoopDetector detector_;

  // ---- state (state_mutex_)
  mutable std::mutex state_mutex_;
  MultiScaleMap map_;
  MagneticSubmapBuilder magnetic_builder_;
  bool map_loaded_ = false;
  std::optional<uint32_t> current_session_;   ///< map session of the run's active VIO session
  uint32_t current_vio_session_ = 0;
  std::vector<PoseGraphNodeId> run_nodes_;    ///< this run's keyframes in time order
  std::deque<PendingKeyframe> pending_;
  /// Described points of the last processed keyframes (node, session, points), newest last: the
  /// local map of the next query (LoopDetectorOptions::query_local_map_keyframes).
  struct RecentPoints {
    PoseGraphNodeId node;
    uint32_t session;
    DescribedPoints points;
  };
  std::deque<RecentPoints> recent_points_;
  std::deque<StoredWindow> windows_;          ///< recent signature windows (query lookup, coverage)
  std::deque<StoredWindow> unplaced_;         ///< windows waiting to be placed on the trajectory
  std::deque<GeomagneticEvent> geomagnetic_;  ///< recent geomagnetic samples
  double latest_signature_t_ = -1e300;
  double latest_geomagnetic_t_ = -1e300;
  double latest_keyframe_t_ = -1e300;
  int keyframes_since_optimisation_ = 0;
  std::vector<LoopAttempt> attempts_;  ///< not yet taken (takeNewLoopAttempts)
  std::optional<DetectionResult> last_detection_;
  PoseGraphManagerStats stats_;
  PoseGraphTimings timings_;
  /// Loops no applied optimisation has included yet, oldest first.
  struct AwaitingLoop {
    std::chrono::steady_clock::time_point accepted;
    double accepted_cpu_s;          ///< thread CPU time at acceptance (synchronous mode)
    LoopEdgeId id;
    PoseGraphNodeId earliest_node;  ///< min(match, query)
    PoseGraphNodeId latest_node;    ///< max(match, query)
    size_t run_keyframes;           ///< run_nodes_.size() at acceptance
  };
  std::deque<AwaitingLoop> loops_awaiting_correction_;
  /// Loops corrected by a local loop solve whose solve from their earliest node is deferred.
  std::deque<AwaitingLoop> loops_awaiting_deferred_solve_;

  // ---- asynchronous mode (queue_mutex_)
  mutable std::mutex queue_mutex_;
  mutable std::condition_variable queue_cv_;     ///< processing thread: new events
  mutable std::condition_variable optimise_cv_;  ///< optimiser thread: new request
  mutable std::condition_variable idle_cv_;      ///< waitForIdle
  std::deque<Event> events_;
  bool processing_busy_ = false;
  bool optimisation_requested_ = false;
  OptimisationTrigger requested_trigger_ = OptimisationTrigger::kPeriodic;  ///< a loop wins when merged
  bool optimising_ = false;
  bool stop_ = false;
  std::thread processing_thread_;
  std::thread optimiser_thread_;
};

}  // namespace vims
