#pragma once
/// @file serial_worker.h
/// @brief Runs submitted tasks one at a time in submission order, on an own thread or inline.
///
/// The offline runner puts the pose graph behind one: its inputs are keyframes, signatures and
/// geomagnetic samples in message-stream order, and nothing it computes flows back into the
/// estimator, so running the same calls in the same order on another thread gives the same
/// outputs while the estimator goes on with the next frames. The queue is bounded so a pose
/// graph that falls behind holds back the producer instead of buffering keyframe images.

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace vims {

class SerialWorker {
 public:
  /// threaded = false: submit() runs the task at once. max_queued: pending tasks beyond which
  /// submit() waits (>= 1).
  SerialWorker(bool threaded, std::size_t max_queued) : max_queued_(max_queued < 1 ? 1 : max_queued) {
    if (threaded) thread_ = std::thread([this] { loop(); });
  }
  ~SerialWorker() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }
  SerialWorker(const SerialWorker&) = delete;
  SerialWorker& operator=(const SerialWorker&) = delete;

  /// Queues `task` (runs it inline without a thread). After a task has thrown, the exception is
  /// rethrown here or in wait() and later tasks are dropped: their order-dependent results
  /// would be meaningless.
  void submit(std::function<void()> task) {
    if (!thread_.joinable()) {
      task();
      return;
    }
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this] { return error_ || tasks_.size() < max_queued_; });
    rethrowLocked();
    tasks_.push_back(std::move(task));
    changed_.notify_all();
  }

  /// Waits until every submitted task has run; rethrows a task's exception.
  void wait() {
    if (!thread_.joinable()) return;
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [this] { return error_ || (tasks_.empty() && !running_); });
    rethrowLocked();
  }

 private:
  void rethrowLocked() {
    if (!error_) return;
    std::exception_ptr error = error_;
    error_ = nullptr;
    failed_ = true;
    std::rethrow_exception(error);
  }

  void loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      changed_.wait(lock, [this] { return stop_ || !tasks_.empty(); });
      if (stop_) return;
      std::function<void()> task = std::move(tasks_.front());
      tasks_.pop_front();
      if (failed_ || error_) {
        changed_.notify_all();
        continue;
      }
      running_ = true;
      lock.unlock();
      std::exception_ptr error;
      try {
        task();
      } catch (...) {
        error = std::current_exception();
      }
      lock.lock();
      running_ = false;
      if (error) error_ = error;
      changed_.notify_all();
    }
  }

  const std::size_t max_queued_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> tasks_;
  bool running_ = false;
  bool stop_ = false;
  bool failed_ = false;       ///< an error was rethrown: drop what is still queued
  std::exception_ptr error_;  ///< thrown by a task, not yet rethrown
};

}  // namespace vims
