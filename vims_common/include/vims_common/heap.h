#pragma once
/// @file heap.h
/// @brief Returning freed heap pages to the operating system in long runs.

namespace vims {

/// Hands the allocator's whole free pages back to the operating system (glibc: malloc_trim(0),
/// every arena); does nothing with other C libraries. Returns false where it is not available.
///
/// Why: the pose graph's solves allocate blocks that grow with the graph, images and descriptor
/// batches come and go on three threads, each with its own glibc arena. Freed, these pages stay
/// resident, so the resident set kept growing by ~20 MB per 1000 s of a 1 h soak after the map
/// had stopped growing, with the heap in use flat (docs/benchmarks_growth.md). It costs a few
/// milliseconds and changes no result.
bool releaseFreeHeapPages();

/// Calls releaseFreeHeapPages() at most once per period of the caller's clock: the long-running
/// holders of the map (vims_offline on the bag clock, the pose-graph node on the wall clock) tick
/// it as they go.
class PeriodicHeapRelease {
 public:
  static constexpr double kDefaultPeriodS = 60.0;
  explicit PeriodicHeapRelease(double period_s = kDefaultPeriodS) : period_s_(period_s) {}
  /// Releases on the first call and then once `period_s` has passed since the last release.
  /// Returns whether it released.
  bool tick(double now_s);

 private:
  double period_s_;
  double last_s_ = 0.0;
  bool released_once_ = false;
};

}  // namespace vims
