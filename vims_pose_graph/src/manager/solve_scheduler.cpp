#include "solve_scheduler.h"

#include <algorithm>
#include <ctime>
#include <stdexcept>

#include "vims_common/timing.h"
#include "vims_pose_graph/pose_graph_factors.h"

namespace vims {

namespace {
constexpr const char* kComponent = "pose_graph_manager";
}  // namespace

std::string toString(OptimisationTrigger trigger) {
  switch (trigger) {
    case OptimisationTrigger::kLoop:
      return "loop";
    case OptimisationTrigger::kDeferredLoops:
      return "deferred_loops";
    case OptimisationTrigger::kFinish:
      return "finish";
    case OptimisationTrigger::kPeriodic:
      break;
  }
  return "periodic";
}

SolveScheduler::SolveScheduler(const PoseGraphManagerOptions& options, LoggerPtr logger, MultiScaleMap& map,
                               const std::vector<PoseGraphNodeId>& run_nodes)
    : options_(options), logger_(std::move(logger)), map_(map), run_nodes_(run_nodes) {}

// ---------------------------------------------------------------------------------------------
// When to optimise
// ---------------------------------------------------------------------------------------------

std::optional<OptimisationTrigger> SolveScheduler::triggerAfterKeyframe() const {
  if (deferredSolveDue()) return OptimisationTrigger::kDeferredLoops;
  if (keyframes_since_optimisation_ >= options_.optimise_every_n_keyframes &&
      (!map_.yawMeasurements().empty() || !map_.loopEdges().empty()))
    return OptimisationTrigger::kPeriodic;
  return std::nullopt;
}

void SolveScheduler::loopAccepted(LoopEdgeId id, PoseGraphNodeId match, PoseGraphNodeId query) {
  loops_awaiting_correction_.push_back(AwaitingLoop{std::chrono::steady_clock::now(), threadCpuSeconds(), id,
                                                    std::min(match, query), std::max(match, query), run_nodes_.size()});
}

bool SolveScheduler::deferredSolveDue() const {
  return !loops_awaiting_deferred_solve_.empty() &&
         run_nodes_.size() >= loops_awaiting_deferred_solve_.front().run_keyframes +
                                  static_cast<size_t>(std::max(1, options_.optimise_every_n_keyframes));
}

// ---------------------------------------------------------------------------------------------
// One solve
// ---------------------------------------------------------------------------------------------

SolvePlan SolveScheduler::planSolve(OptimisationTrigger trigger) const {
  SolvePlan plan;
  if (map_.numNodes() == 0) return plan;
  std::vector<ComponentSnapshot>& snapshots = plan.snapshots;
  snapshots.push_back(map_.snapshotComponent(0));
  if (!run_nodes_.empty() && !map_.sameComponent(0, run_nodes_.back()))
    snapshots.push_back(map_.snapshotComponent(run_nodes_.back()));
  plan.loops_included = loops_awaiting_correction_.size();

  // What this solve optimises (global node ids; nodes are numbered in time order within a run,
  // loaded maps first):
  // - after new loops that the map already agrees with (local loop solve): the newest
  //   window_keyframes and the loops' query nodes; the match side is held;
  // - after other new loops: everything from the earliest node they, and the loops waiting for
  //   their deferred solve, touch (as VINS-Mono): older nodes are not in the new cycles;
  // - the deferred solve of loops corrected locally: from their earliest node on;
  // - otherwise (periodic, yaw factors of the newest keyframes): the newest window_keyframes;
  // - at the end of data: the whole graph, converged to the tighter function_tolerance.
  const PoseGraphOptions& g = options_.graph;
  const bool has_window = g.window_keyframes > 0 && run_nodes_.size() > static_cast<size_t>(g.window_keyframes);
  const PoseGraphNodeId window_start =
      has_window ? run_nodes_[run_nodes_.size() - static_cast<size_t>(g.window_keyframes)] : 0;
  auto earliestOf = [](const std::deque<AwaitingLoop>& loops, PoseGraphNodeId first) {
    for (const AwaitingLoop& l : loops) first = std::min(first, l.earliest_node);
    return first;
  };
  PoseGraphNodeId first_free = 0;
  if (trigger == OptimisationTrigger::kFinish) {
    plan.deferred_included = loops_awaiting_deferred_solve_.size();
  } else if (!loops_awaiting_correction_.empty()) {
    for (const AwaitingLoop& l : loops_awaiting_correction_) {
      const auto it = std::find_if(map_.loopEdges().begin(), map_.loopEdges().end(),
                                   [&](const LoopEdge& e) { return e.id == l.id; });
      if (it == map_.loopEdges().end() || !it->enabled) continue;
      const MapNode& m = map_.node(it->match);
      const MapNode& q = map_.node(it->query);
      const Eigen::Vector4d r =
          relativePose4DofResidual(m.pose.p_w_b, m.pose.yaw_w_b, q.pose.p_w_b, q.pose.yaw_w_b, it->measurement);
      plan.max_new_loop_sigmas = std::max(plan.max_new_loop_sigmas, it->sqrt_information.cwiseProduct(r).norm());
    }
    plan.local = g.loop_local_solve_max_sigmas > 0.0 && g.window_keyframes > 0 &&
                 plan.max_new_loop_sigmas <= g.loop_local_solve_max_sigmas && !deferredSolveDue();
    if (plan.local) {
      first_free = window_start;
      for (const AwaitingLoop& l : loops_awaiting_correction_) first_free = std::min(first_free, l.latest_node);
    } else {
      plan.deferred_included = loops_awaiting_deferred_solve_.size();
      if (g.loop_solve_from_earliest_node)
        first_free =
            earliestOf(loops_awaiting_deferred_solve_,
                       earliestOf(loops_awaiting_correction_, loops_awaiting_correction_.front().earliest_node));
    }
  } else if (deferredSolveDue()) {
    // By state, not trigger: asynchronous requests merge, and a request repeated while the
    // deferred solve ran must not start another one for loops that are not due yet.
    plan.deferred_included = loops_awaiting_deferred_solve_.size();
    if (g.loop_solve_from_earliest_node)
      first_free = earliestOf(loops_awaiting_deferred_solve_, loops_awaiting_deferred_solve_.front().earliest_node);
  } else {
    first_free = window_start;
  }
  // A loaded map is node 0 onwards (loaded before the run's first keyframe), so the run's first
  // keyframe id is the map's size: held, the map is the fixed reference the run is placed in.
  if (hold_loaded_map_ && !run_nodes_.empty()) first_free = std::max(first_free, run_nodes_.front());
  // The convex Huber stage is considered for loops not in any solve yet.
  LoopEdgeId first_new_loop = 0;  // no new loops: past the newest id
  if (!loops_awaiting_correction_.empty())
    first_new_loop = loops_awaiting_correction_.front().id;
  else
    for (const LoopEdge& e : map_.loopEdges()) first_new_loop = std::max(first_new_loop, e.id + 1);
  for (ComponentSnapshot& cs : snapshots) {
    if (trigger != OptimisationTrigger::kFinish) cs.snapshot.options.function_tolerance = g.online_function_tolerance;
    cs.snapshot.first_free_node =
        static_cast<size_t>(std::lower_bound(cs.ids.begin(), cs.ids.end(), first_free) - cs.ids.begin());
    cs.snapshot.first_new_loop_id = first_new_loop;
  }
  return plan;
}

double SolveScheduler::newestKeyframeTime() const {
  return run_nodes_.empty() ? 0.0 : map_.node(run_nodes_.back()).pose.t;
}

std::vector<PoseGraphSolution> SolveScheduler::solveSnapshots(const std::vector<ComponentSnapshot>& snapshots,
                                                              OptimisationTrigger trigger, double t_keyframe,
                                                              std::vector<OptimisationRecord>* records) const {
  std::vector<PoseGraphSolution> solutions;
  for (const ComponentSnapshot& s : snapshots) {
    const double cpu_start = threadCpuSeconds();
    const auto start = std::chrono::steady_clock::now();
    solutions.push_back(PoseGraph4Dof::solve(s.snapshot));
    OptimisationRecord record;
    record.trigger = trigger;
    record.t_keyframe = t_keyframe;
    record.solve_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    record.solve_cpu_ms = 1e3 * (threadCpuSeconds() - cpu_start);
    // The record keeps the report without its loop residuals (one per loop edge of the snapshot;
    // nothing after the solve reads them): records are kept for the whole run, and a cleared copy
    // kept each buffer, so the held memory grew with solves x loops (~250 MB over a 1 h soak).
    std::vector<LoopEdgeResidual>().swap(solutions.back().report.loop_residuals);
    record.report = solutions.back().report;
    const PoseGraphReport& r = record.report;
    logger_->debug(kComponent,
                   VIMS_STR("optimised (" << toString(trigger) << ") " << r.num_nodes << " nodes, " << r.num_loop_edges
                                          << " loops, " << r.num_yaw_factors << " yaw factors: cost " << r.initial_cost
                                          << " -> " << r.final_cost << ", " << r.iterations << " iterations, "
                                          << record.solve_ms << " ms (" << r.message << ")"));
    records->push_back(std::move(record));
  }
  return solutions;
}

void SolveScheduler::applySolutions(const SolvePlan& plan, const std::vector<PoseGraphSolution>& solutions,
                                    std::vector<OptimisationRecord> records) {
  for (size_t i = 0; i < plan.snapshots.size(); ++i) map_.applySolution(plan.snapshots[i], solutions[i]);
  ++optimisations_;
  const auto now = std::chrono::steady_clock::now();
  const double cpu_now = threadCpuSeconds();
  // Loops accepted while an asynchronous solve ran are behind the included ones and stay.
  for (size_t i = 0; i < plan.deferred_included && !loops_awaiting_deferred_solve_.empty(); ++i)
    loops_awaiting_deferred_solve_.pop_front();
  for (size_t i = 0; i < plan.loops_included && !loops_awaiting_correction_.empty(); ++i) {
    const AwaitingLoop& l = loops_awaiting_correction_.front();
    timings_.loop_correction_ms.push_back(1e3 * std::chrono::duration<double>(now - l.accepted).count());
    if (options_.synchronous) timings_.loop_correction_cpu_ms.push_back(1e3 * (cpu_now - l.accepted_cpu_s));
    if (plan.local) loops_awaiting_deferred_solve_.push_back(l);
    loops_awaiting_correction_.pop_front();
  }
  for (OptimisationRecord& r : records) {
    r.max_new_loop_sigmas = plan.max_new_loop_sigmas;
    r.local_loop_solve = plan.local;
    timings_.solves.push_back(std::move(r));
  }
}

void SolveScheduler::solveNow(OptimisationTrigger trigger) {
  if (map_.numNodes() == 0) return;
  const SolvePlan plan = planSolve(trigger);
  std::vector<OptimisationRecord> records;
  const std::vector<PoseGraphSolution> solutions =
      solveSnapshots(plan.snapshots, trigger, newestKeyframeTime(), &records);
  applySolutions(plan, solutions, std::move(records));
}

// ---------------------------------------------------------------------------------------------
// Records
// ---------------------------------------------------------------------------------------------

PoseGraphTimings SolveScheduler::timings(size_t first_solve) const {
  PoseGraphTimings t;
  if (first_solve < timings_.solves.size())
    t.solves.assign(timings_.solves.begin() + static_cast<std::ptrdiff_t>(first_solve), timings_.solves.end());
  t.loop_correction_ms = timings_.loop_correction_ms;
  t.loop_correction_cpu_ms = timings_.loop_correction_cpu_ms;
  return t;
}

}  // namespace vims
