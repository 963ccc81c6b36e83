#pragma once
/// @file pose_graph_thread_runner.h
/// @brief PoseGraphManager's asynchronous mode: one queue of input events, a processing thread
/// that runs them on PoseGraphManagerCore (describing keyframes outside the map lock), and an
/// optimiser thread that plans a solve under the map lock, runs PoseGraph4Dof::solve without
/// it, and applies the solution under it, so that neither feeding nor reading outputs waits for
/// a solve. Lock order: the map lock, then the queue lock.

#include <Eigen/Geometry>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <variant>

#include "pose_graph_manager_core.h"
#include "vims_common/keyframe_data.h"
#include "vims_common/log.h"
#include "vims_common/magnetic_signature.h"
#include "vims_pose_graph/pose_graph_outputs.h"

namespace vims {

/// End of data (PoseGraphManager::finish).
struct FinishEvent {};
/// One input of the manager, in feed order.
using PoseGraphEvent = std::variant<KeyframeData, SignatureWindow, GeomagneticMeasurement, FinishEvent>;

/// Runs one event on the core: a keyframe is described without `state_mutex` (the expensive
/// part, no map state), then every event is handled under it. The synchronous facade calls this
/// inline; the processing thread calls it for each queued event.
void runEvent(PoseGraphManagerCore& core, std::mutex& state_mutex, const PoseGraphEvent& event);

class PoseGraphThreadRunner {
 public:
  /// Hands the core's optimisation requests to the optimiser thread and starts both threads.
  /// `core` and `state_mutex` (which guards it) must outlive the runner.
  PoseGraphThreadRunner(PoseGraphManagerCore& core, std::mutex& state_mutex, LoggerPtr logger);
  /// Stops the threads (see stop()).
  ~PoseGraphThreadRunner();
  PoseGraphThreadRunner(const PoseGraphThreadRunner&) = delete;
  PoseGraphThreadRunner& operator=(const PoseGraphThreadRunner&) = delete;

  void enqueue(PoseGraphEvent event);
  /// Blocks until the queue is empty and no solve is running or requested (or the runner stops).
  void waitForIdle() const;
  /// Stops and joins the threads; queued events and requested solves are dropped.
  void stop();

 private:
  /// The core's request (map lock held): wakes the optimiser thread; requests during a solve
  /// merge into one, which reports the most specific trigger.
  void requestOptimisation(OptimisationTrigger trigger);
  void processingLoop();
  void optimiserLoop();
  /// Plans under the map lock, solves without it, applies under it.
  void optimise(OptimisationTrigger trigger);

  PoseGraphManagerCore& core_;
  std::mutex& state_mutex_;
  LoggerPtr logger_;

  mutable std::mutex queue_mutex_;
  mutable std::condition_variable queue_cv_;     ///< processing thread: new events
  mutable std::condition_variable optimise_cv_;  ///< optimiser thread: new request
  mutable std::condition_variable idle_cv_;      ///< waitForIdle
  std::deque<PoseGraphEvent> events_;
  bool processing_busy_ = false;
  bool optimisation_requested_ = false;
  OptimisationTrigger requested_trigger_ = OptimisationTrigger::kPeriodic;  ///< a loop wins when merged
  bool optimising_ = false;
  bool stop_ = false;
  std::thread processing_thread_;
  std::thread optimiser_thread_;
};

}  // namespace vims
