#pragma once
/// @file solve_scheduler.h
/// @brief When and what PoseGraphManagerCore optimises: the loop, periodic, deferred-loop and
/// finish triggers, the SolvePlan of each solve (docs/pose_graph.md, "Cost of the optimisation",
/// "Local loop solves"), applying the solutions, and the loop-correction latency and solve timing
/// records (PoseGraphTimings). Not thread-safe: the caller holds the map lock, except around
/// solveSnapshots, which reads only its snapshots.

#include <chrono>
#include <cstddef>
#include <deque>
#include <optional>
#include <vector>

#include "vims_common/log.h"
#include "vims_pose_graph/loop_closing_options.h"
#include "vims_pose_graph/multiscale_map.h"
#include "vims_pose_graph/pose_graph_outputs.h"

namespace vims {

/// One solve: snapshots of the components to optimise and which waiting loops it covers.
struct SolvePlan {
  std::vector<ComponentSnapshot> snapshots;
  size_t loops_included = 0;     ///< the first this many of the loops awaiting correction
  bool local = false;            ///< a local loop solve: those loops then await the deferred solve
  size_t deferred_included = 0;  ///< the first this many of the loops awaiting the deferred solve
  double max_new_loop_sigmas = 0.0;
};

class SolveScheduler {
 public:
  /// `map` and `run_nodes` (this run's keyframes in time order) belong to the core that owns
  /// the scheduler and outlive it.
  SolveScheduler(const PoseGraphManagerOptions& options, LoggerPtr logger, MultiScaleMap& map,
                 const std::vector<PoseGraphNodeId>& run_nodes);

  // ---- when to optimise
  /// A keyframe joined the run: counts towards the periodic solve.
  void keyframeAdded() { ++keyframes_since_optimisation_; }
  /// After a keyframe: the deferred solve of locally corrected loops when it is due, else the
  /// periodic solve every optimise_every_n_keyframes keyframes once the graph has yaw factors or
  /// loops, else none.
  std::optional<OptimisationTrigger> triggerAfterKeyframe() const;
  /// A loop edge was accepted: it awaits its correction (latency measured from now).
  void loopAccepted(LoopEdgeId id, PoseGraphNodeId match, PoseGraphNodeId query);
  /// An optimisation was requested (whatever the trigger): the periodic count restarts.
  void optimisationRequested() { keyframes_since_optimisation_ = 0; }
  /// Whether a loaded map is held where the map file had it (MapMode extend, localisation) or
  /// optimised with the run (mapping); from the next solve on.
  void setHoldLoadedMap(bool hold) { hold_loaded_map_ = hold; }

  // ---- one solve: plan (map lock held), solve (no lock needed), apply (map lock held)
  /// Snapshots of the components to optimise (reference component, and the run's if separate),
  /// with the part to optimise for this trigger and state (docs/pose_graph.md, "Cost of the
  /// optimisation", "Local loop solves").
  SolvePlan planSolve(OptimisationTrigger trigger) const;
  /// Time of the newest keyframe of the run (0 before the first): the records' t_keyframe.
  double newestKeyframeTime() const;
  /// Solves the snapshots and records their timing (no lock needed).
  std::vector<PoseGraphSolution> solveSnapshots(const std::vector<ComponentSnapshot>& snapshots,
                                                OptimisationTrigger trigger, double t_keyframe,
                                                std::vector<OptimisationRecord>* records) const;
  /// Applies solutions and records the loop correction latency of the loops they include.
  void applySolutions(const SolvePlan& plan, const std::vector<PoseGraphSolution>& solutions,
                      std::vector<OptimisationRecord> records);
  /// Synchronous mode: plans, solves and applies now (nothing when the map is empty).
  void solveNow(OptimisationTrigger trigger);

  // ---- records
  /// The solves from index `first_solve` on (0: all) and every loop correction latency so far.
  PoseGraphTimings timings(size_t first_solve) const;
  size_t optimisations() const { return optimisations_; }  ///< applied solves (PoseGraphManagerStats)

 private:
  /// A loop no applied optimisation has included yet (or whose deferred solve is still due).
  struct AwaitingLoop {
    std::chrono::steady_clock::time_point accepted;
    double accepted_cpu_s;  ///< thread CPU time at acceptance (synchronous mode)
    LoopEdgeId id;
    PoseGraphNodeId earliest_node;  ///< min(match, query)
    PoseGraphNodeId latest_node;    ///< max(match, query)
    size_t run_keyframes;           ///< run_nodes_.size() at acceptance
  };
  /// Whether the loops corrected by local loop solves are due for their deferred solve.
  bool deferredSolveDue() const;

  PoseGraphManagerOptions options_;
  LoggerPtr logger_;
  MultiScaleMap& map_;
  const std::vector<PoseGraphNodeId>& run_nodes_;
  int keyframes_since_optimisation_ = 0;
  bool hold_loaded_map_ = false;
  size_t optimisations_ = 0;
  PoseGraphTimings timings_;
  /// Loops no applied optimisation has included yet, oldest first.
  std::deque<AwaitingLoop> loops_awaiting_correction_;
  /// Loops corrected by a local loop solve whose solve from their earliest node is deferred.
  std::deque<AwaitingLoop> loops_awaiting_deferred_solve_;
};

}  // namespace vims
