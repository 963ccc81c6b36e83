/// @file test_serial_worker.cpp
/// @brief SerialWorker: submission order, the bounded queue, inline mode and task failures.

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "../src/serial_worker.h"

namespace vims {
namespace {

TEST(SerialWorker, RunsTasksInSubmissionOrderOnItsThread) {
  std::vector<int> order;  // touched by the worker only until wait()
  std::atomic<int> on_caller_thread{0};
  const std::thread::id caller = std::this_thread::get_id();
  SerialWorker worker(true, 3);
  for (int i = 0; i < 500; ++i) {
    worker.submit([&, i] {
      if (std::this_thread::get_id() == caller) ++on_caller_thread;
      if (i % 50 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // let the queue fill
      order.push_back(i);
    });
  }
  worker.wait();
  ASSERT_EQ(order.size(), 500u);
  for (int i = 0; i < 500; ++i) EXPECT_EQ(order[static_cast<size_t>(i)], i);
  EXPECT_EQ(on_caller_thread.load(), 0);
}

TEST(SerialWorker, QueueNeverHoldsMoreThanItsBound) {
  std::atomic<int> started{0};
  std::atomic<int> submitted{0};
  std::atomic<int> max_backlog{0};
  SerialWorker worker(true, 2);
  for (int i = 0; i < 40; ++i) {
    worker.submit([&] {
      ++started;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    });
    ++submitted;
    // Submitted but not yet started: the queued tasks plus at most the one being started.
    max_backlog = std::max(max_backlog.load(), submitted.load() - started.load());
  }
  worker.wait();
  EXPECT_EQ(started.load(), 40);
  EXPECT_LE(max_backlog.load(), 3);
}

TEST(SerialWorker, WithoutAThreadRunsEachTaskInsideSubmit) {
  SerialWorker worker(false, 1);
  const std::thread::id caller = std::this_thread::get_id();
  int ran = 0;
  worker.submit([&] {
    EXPECT_EQ(std::this_thread::get_id(), caller);
    ++ran;
  });
  EXPECT_EQ(ran, 1);
  worker.wait();
  EXPECT_THROW(worker.submit([] { throw std::runtime_error("inline"); }), std::runtime_error);
}

TEST(SerialWorker, AFailedTaskIsRethrownAndLaterTasksAreDropped) {
  SerialWorker worker(true, 10);
  std::atomic<int> after{0};
  worker.submit([] { throw std::runtime_error("pose graph failed"); });
  try {
    for (int i = 0; i < 5; ++i) worker.submit([&] { ++after; });
    worker.wait();
    FAIL() << "the task's exception was not rethrown";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "pose graph failed");
  }
  worker.wait();  // rethrown once; what was queued behind it never runs
  EXPECT_EQ(after.load(), 0);
}

}  // namespace
}  // namespace vims
