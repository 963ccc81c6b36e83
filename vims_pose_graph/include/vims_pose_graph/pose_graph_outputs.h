#pragma once
/// @file pose_graph_outputs.h
/// @brief What PoseGraphManager hands out (keyframe poses, loop edges, map contents, stats,
/// optimisation timings) and why it optimised. Its own header so that the manager's parts
/// (PoseGraphManagerCore, SolveScheduler, PoseGraphThreadRunner) share them without the facade.

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "vims_pose_graph/loop_closing_options.h"
#include "vims_pose_graph/pose_graph.h"

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
  std::vector<PoseGraphNodeId> clustered;                   ///< visual submaps within radius + cluster margin
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
  /// Keyframes whose visual submap was not stored because the run was localising (MapMode);
  /// they still ran their loop query.
  size_t localisation_keyframes = 0;
  /// Keyframes that ran no loop query because the run was localised and its loops into the map
  /// kept coming (PoseGraphManagerOptions::localisation_query_interval_s).
  size_t localisation_skipped_queries = 0;
  /// Keyframes of a mapping or extending run that were no place and ran no loop query: a place
  /// was made less than PoseGraphManagerOptions::place_min_interval_s before.
  size_t thinned_places = 0;
  size_t loaded_keyframes = 0;
  size_t sessions = 0;  ///< of this run
  size_t loop_queries = 0;
  size_t loop_attempts = 0;
  size_t loops_accepted = 0;
  size_t yaw_factors = 0;
  size_t yaw_rejected = 0;  ///< geomagnetic samples the gate found disturbed (GeomagneticGate)
  /// The vehicle's own field is being taken out of the geomagnetic samples (VehicleFieldEstimator::
  /// applied), and how much of their spread its fit explains.
  bool vehicle_field_taken_out = false;
  double vehicle_field_explained = 0.0;
  size_t magnetic_submaps = 0;
  size_t optimisations = 0;
  bool relocalised = false;
  /// t_query of the first accepted loop between the run and the loaded map (when relocalised):
  /// from then on the run is expressed in the map's frame.
  double relocalised_t = 0.0;
  /// Accepted loops whose match is a keyframe of the loaded map, and the t_query of the newest.
  size_t loops_into_map = 0;
  double last_loop_into_map_t = 0.0;
};

/// Where a teach-and-repeat run stands (the pose-graph node's latched status topic).
struct RelocalisationStatus {
  MapMode map_mode = MapMode::kMapping;
  bool map_loaded = false;
  std::string map_path;               ///< the loaded file (empty without)
  size_t loaded_keyframes = 0;        ///< keyframes of the loaded map
  bool relocalised = false;           ///< a loop into the loaded map was accepted
  double relocalised_t = 0.0;         ///< t_query of the first (when relocalised)
  size_t loops_into_map = 0;          ///< accepted loops into the loaded map so far
  double last_loop_into_map_t = 0.0;  ///< t_query of the newest (when loops_into_map > 0)
  double latest_keyframe_t = 0.0;     ///< the run's newest keyframe (0 before the first)
  size_t run_keyframes = 0;           ///< this run's keyframes in the graph
  Eigen::Isometry3d T_map_odom = Eigen::Isometry3d::Identity();
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
  PoseGraphReport report;  ///< without loop residuals
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

}  // namespace vims
