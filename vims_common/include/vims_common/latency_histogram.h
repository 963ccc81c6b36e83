#pragma once
/// @file latency_histogram.h
/// @brief Bounded-memory distribution of latencies for the runners' p50/p99 summaries.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vims {

/// Latencies [ms] in logarithmic bins 1 % wide, from 1 ns to ~3 h: a fixed ~24 KB whatever the
/// number of samples. A run keeps one per stage for its whole length (the magnetometer's is fed
/// 1000 times a second), so keeping every sample grew memory with the run's length, not with the
/// map (8 MB per 1000 s for the magnetometer alone).
///
/// percentile() is the nearest-rank percentile of the bins: the geometric middle of the bin that
/// holds the exact nearest-rank sample, clamped to the smallest and largest sample, so it is within
/// 0.5 % of the exact value; the first and last ranks are the exact smallest and largest sample.
/// count(), sum(), min() and max() are exact.
class LatencyHistogram {
 public:
  LatencyHistogram();

  /// Adds one latency [ms]. Values below 1 ns (0 included; a negative one can only be a clock
  /// error) count in the first bin; NaN is not counted (the caller logs its own bad input).
  void add(double ms);

  std::size_t count() const { return count_; }
  /// Sum of all added values [ms] (stage totals).
  double sum() const { return sum_; }
  double min() const;  ///< 0 when empty
  double max() const;  ///< 0 when empty
  /// Nearest-rank percentile, q in [0, 1] (clamped); 0 when empty.
  double percentile(double q) const;

  /// Relative width of a bin (upper / lower bound - 1).
  static constexpr double kRelativeBinWidth = 0.01;

 private:
  std::size_t binOf(double ms) const;
  /// Geometric middle of bin `i` (lower bound for the first, which also holds everything below).
  double representative(std::size_t i) const;

  std::vector<std::uint64_t> bins_;
  std::size_t count_ = 0;
  double sum_ = 0.0;
  double min_ = 0.0;
  double max_ = 0.0;
};

}  // namespace vims
