#pragma once
/// @file timing.h
/// @brief Clocks and a percentile for the runtime figures of the pipeline, its benches and tools.

#include <chrono>
#include <vector>

namespace vims {

/// CPU time of the calling thread [s]: unlike wall time it does not grow when other processes
/// compete for the cores, so it measures the work itself. 0 if the clock is unavailable.
double threadCpuSeconds();
/// CPU time of the whole process, every thread [s]; 0 if the clock is unavailable.
double processCpuSeconds();

/// Wall time since `start` on the steady clock [ms].
double millisecondsSince(std::chrono::steady_clock::time_point start);

/// The q-quantile (q in [0, 1]) of `values`: the sorted value at index round(q (n - 1)), so 0.5
/// is the median (the upper of the two middle values for even n) and 1 the maximum; NaN for an
/// empty set.
double percentile(std::vector<double> values, double q);

}  // namespace vims
