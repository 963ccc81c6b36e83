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
/// had stopped growing, with the heap in use flat (docs/benchmarks_growth.md). The long-running
/// holders of the map (vims_offline, the pose-graph node) call this about once a minute; it costs
/// a few milliseconds and changes no result.
bool releaseFreeHeapPages();

}  // namespace vims
