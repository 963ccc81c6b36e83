#include "pose_graph_thread_runner.h"

#include <exception>
#include <utility>

namespace vims {

namespace {
constexpr const char* kComponent = "pose_graph_manager";

/// Merged requests report the most specific trigger: finish, then loop, then deferred loops.
int triggerRank(OptimisationTrigger trigger) {
  switch (trigger) {
    case OptimisationTrigger::kFinish:
      return 3;
    case OptimisationTrigger::kLoop:
      return 2;
    case OptimisationTrigger::kDeferredLoops:
      return 1;
    case OptimisationTrigger::kPeriodic:
      break;
  }
  return 0;
}
}  // namespace

void runEvent(PoseGraphManagerCore& core, std::mutex& state_mutex, const PoseGraphEvent& event) {
  if (const auto* kf = std::get_if<KeyframeData>(&event)) {
    // Description is the expensive part (ORB, BoW, replication); it needs no map state, so it
    // runs without the lock (only whether it is wanted does).
    bool query = true;
    {
      std::lock_guard<std::mutex> lk(state_mutex);
      query = core.wantsQuery(kf->t);
    }
    KeyframeDescription description = query ? core.describe(*kf) : KeyframeDescription();
    std::lock_guard<std::mutex> lk(state_mutex);
    core.addKeyframe(*kf, std::move(description), query);
  } else if (const auto* w = std::get_if<SignatureWindow>(&event)) {
    std::lock_guard<std::mutex> lk(state_mutex);
    core.addSignature(*w);
  } else if (const auto* g = std::get_if<GeomagneticMeasurement>(&event)) {
    std::lock_guard<std::mutex> lk(state_mutex);
    core.addGeomagnetic(g->t, g->field_body);
  } else {
    std::lock_guard<std::mutex> lk(state_mutex);
    core.finish();
  }
}

PoseGraphThreadRunner::PoseGraphThreadRunner(PoseGraphManagerCore& core, std::mutex& state_mutex, LoggerPtr logger)
    : core_(core), state_mutex_(state_mutex), logger_(std::move(logger)) {
  {
    std::lock_guard<std::mutex> lk(state_mutex_);
    core_.handOptimisationRequestsTo([this](OptimisationTrigger trigger) { requestOptimisation(trigger); });
  }
  processing_thread_ = std::thread([this] { processingLoop(); });
  optimiser_thread_ = std::thread([this] { optimiserLoop(); });
}

PoseGraphThreadRunner::~PoseGraphThreadRunner() {
  stop();
  // The core outlives the runner: it must not call back into it.
  std::lock_guard<std::mutex> lk(state_mutex_);
  core_.handOptimisationRequestsTo(nullptr);
}

void PoseGraphThreadRunner::stop() {
  {
    std::lock_guard<std::mutex> lk(queue_mutex_);
    stop_ = true;
  }
  queue_cv_.notify_all();
  optimise_cv_.notify_all();
  idle_cv_.notify_all();
  if (processing_thread_.joinable()) processing_thread_.join();
  if (optimiser_thread_.joinable()) optimiser_thread_.join();
}

void PoseGraphThreadRunner::enqueue(PoseGraphEvent event) {
  {
    std::lock_guard<std::mutex> lk(queue_mutex_);
    events_.push_back(std::move(event));
  }
  queue_cv_.notify_one();
}

void PoseGraphThreadRunner::waitForIdle() const {
  std::unique_lock<std::mutex> lk(queue_mutex_);
  idle_cv_.wait(
      lk, [&] { return stop_ || (events_.empty() && !processing_busy_ && !optimisation_requested_ && !optimising_); });
}

void PoseGraphThreadRunner::requestOptimisation(OptimisationTrigger trigger) {
  {
    std::lock_guard<std::mutex> lk(queue_mutex_);  // lock order: state, then queue
    optimisation_requested_ = true;
    if (triggerRank(trigger) > triggerRank(requested_trigger_)) requested_trigger_ = trigger;
  }
  optimise_cv_.notify_one();
}

void PoseGraphThreadRunner::processingLoop() {
  for (;;) {
    PoseGraphEvent event;
    {
      std::unique_lock<std::mutex> lk(queue_mutex_);
      queue_cv_.wait(lk, [&] { return stop_ || !events_.empty(); });
      if (stop_) return;
      event = std::move(events_.front());
      events_.pop_front();
      processing_busy_ = true;  // in the same critical section as the pop: never "idle" in between
    }
    try {
      runEvent(core_, state_mutex_, event);
    } catch (const std::exception& e) {
      logger_->error(kComponent, VIMS_STR("processing failed: " << e.what()));
    }
    {
      std::lock_guard<std::mutex> lk(queue_mutex_);
      processing_busy_ = false;
    }
    idle_cv_.notify_all();
  }
}

void PoseGraphThreadRunner::optimiserLoop() {
  for (;;) {
    OptimisationTrigger trigger;
    {
      std::unique_lock<std::mutex> lk(queue_mutex_);
      optimise_cv_.wait(lk, [&] { return stop_ || optimisation_requested_; });
      if (stop_) return;
      optimisation_requested_ = false;
      trigger = requested_trigger_;
      requested_trigger_ = OptimisationTrigger::kPeriodic;
      optimising_ = true;
    }
    try {
      optimise(trigger);
    } catch (const std::exception& e) {
      logger_->error(kComponent, VIMS_STR("optimisation failed: " << e.what()));
    }
    {
      std::lock_guard<std::mutex> lk(queue_mutex_);
      optimising_ = false;
    }
    idle_cv_.notify_all();
  }
}

void PoseGraphThreadRunner::optimise(OptimisationTrigger trigger) {
  SolveScheduler& scheduler = core_.scheduler();
  SolvePlan plan;
  double t_keyframe = 0.0;
  {
    std::lock_guard<std::mutex> lk(state_mutex_);
    plan = scheduler.planSolve(trigger);
    t_keyframe = scheduler.newestKeyframeTime();
  }
  // The solve runs without the map lock: keyframes keep arriving and outputs stay readable.
  std::vector<OptimisationRecord> records;
  const std::vector<PoseGraphSolution> solutions =
      scheduler.solveSnapshots(plan.snapshots, trigger, t_keyframe, &records);
  std::lock_guard<std::mutex> lk(state_mutex_);
  scheduler.applySolutions(plan, solutions, std::move(records));
}

}  // namespace vims
