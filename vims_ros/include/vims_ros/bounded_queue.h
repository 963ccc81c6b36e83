#pragma once
/// @file bounded_queue.h
/// @brief A bounded FIFO between ROS callbacks and a node's processing thread (ROS-free).
///
/// Callbacks push and never block: when the queue is full the *incoming* item is refused
/// (push returns false, and the caller logs the drop), so what was queued keeps its order and
/// the consumer sees a prefix-preserving subsequence of what arrived. The consumer blocks in
/// pop() until an item arrives or the queue is closed; after close() it still drains the items
/// that were queued before (so a node's last inputs are processed at shutdown).

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>

namespace vims {

template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(std::size_t capacity) : capacity_(capacity) {
    if (capacity_ == 0) throw std::invalid_argument("BoundedQueue: capacity must be > 0");
  }

  /// Appends `item` unless the queue is full or closed; false means it was dropped.
  bool push(T item) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (closed_ || items_.size() >= capacity_) {
        ++dropped_;
        return false;
      }
      items_.push_back(std::move(item));
    }
    cv_.notify_one();
    return true;
  }

  /// The oldest item; waits while the queue is empty and open. nullopt once closed and empty.
  std::optional<T> pop() {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return closed_ || !items_.empty(); });
    if (items_.empty()) return std::nullopt;
    T item = std::move(items_.front());
    items_.pop_front();
    return item;
  }

  /// Refuses further pushes and wakes the consumer; queued items are still popped.
  void close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    cv_.notify_all();
  }

  std::size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.size();
  }
  std::size_t capacity() const { return capacity_; }
  /// Items refused so far (full or closed).
  std::size_t dropped() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return dropped_;
  }

 private:
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<T> items_;
  bool closed_ = false;
  std::size_t dropped_ = 0;
};

}  // namespace vims
