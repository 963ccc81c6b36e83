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
///
/// Parts (src/manager/). This class is the facade: it records the inputs, owns the map lock and
/// either runs each input inline or hands it to the thread runner. PoseGraphManagerCore does
/// the work (keyframes, signatures, geomagnetic field, map, loop closing, map files, outputs)
/// inline and knows nothing about threads; its SolveScheduler decides when and what to optimise
/// and applies the solutions; PoseGraphThreadRunner is the asynchronous mode (event queue,
/// processing and optimiser threads).

#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "vims_common/keyframe_data.h"
#include "vims_common/log.h"
#include "vims_common/magnetic_signature.h"
#include "vims_common/sequence_config.h"
#include "vims_pose_graph/input_recording.h"
#include "vims_pose_graph/keyframe_description.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_pose_graph/loop_detector.h"
#include "vims_pose_graph/magnetic_submap.h"
#include "vims_pose_graph/multiscale_map.h"
#include "vims_pose_graph/pose_graph_outputs.h"

namespace vims {

class PoseGraphManagerCore;
class PoseGraphThreadRunner;

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
  /// the last keyframes and the open magnetic submap). Localising, only the loaded map is
  /// written (MapSaveScope::kLoadedSessions). Throws std::runtime_error on I/O errors.
  void saveMap(const std::string& path) const;
  /// Switches what the run does with the loaded map (MapMode) from the next keyframe and solve
  /// on. Throws std::invalid_argument for extend or localisation without a loaded map. A mode
  /// other than mapping in the options without a map loaded by the first keyframe falls back to
  /// mapping with a warning.
  void setMapMode(MapMode mode);
  /// The run's relocalisation state in the loaded map (thread-safe snapshot).
  RelocalisationStatus relocalisationStatus() const;

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
  PoseGraphManagerOptions options_;
  ModeSettings mode_;
  LoggerPtr logger_;
  std::unique_ptr<InputRecorder> recorder_;  ///< options_.record_inputs_path; written by the feed calls
  std::mutex recorder_mutex_;
  /// Guards core_ (and the solve scheduler in it): the feed path, the optimiser thread and the
  /// output getters take it. Lock order: this one, then the thread runner's queue lock.
  mutable std::mutex state_mutex_;
  std::unique_ptr<PoseGraphManagerCore> core_;
  std::unique_ptr<PoseGraphThreadRunner> runner_;  ///< asynchronous mode only; stopped before core_ goes
};

}  // namespace vims
