#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "vims_common/latency_histogram.h"

namespace vims {
namespace {

/// Nearest-rank percentile of the samples themselves (what the histogram approximates).
double exactPercentile(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank > 0 ? rank - 1 : 0)];
}

TEST(LatencyHistogram, EmptyGivesZeros) {
  const LatencyHistogram h;
  EXPECT_EQ(h.count(), 0u);
  EXPECT_EQ(h.sum(), 0.0);
  EXPECT_EQ(h.percentile(0.5), 0.0);
  EXPECT_EQ(h.percentile(0.99), 0.0);
  EXPECT_EQ(h.max(), 0.0);
}

TEST(LatencyHistogram, PercentilesWithinHalfAPercentOfTheExactNearestRank) {
  // Latencies spread over six decades (a magnetometer sample's microseconds to a solve's
  // seconds), log-uniform, plus ties.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> exponent(-4.0, 3.0);
  std::vector<double> samples;
  LatencyHistogram h;
  double sum = 0.0;
  for (int i = 0; i < 20000; ++i) {
    const double ms = i % 10 == 0 ? 2.5 : std::pow(10.0, exponent(rng));
    samples.push_back(ms);
    h.add(ms);
    sum += ms;
  }
  EXPECT_EQ(h.count(), samples.size());
  EXPECT_NEAR(h.sum(), sum, 1e-9 * sum);
  EXPECT_EQ(h.min(), *std::min_element(samples.begin(), samples.end()));
  EXPECT_EQ(h.max(), *std::max_element(samples.begin(), samples.end()));
  for (double q : {0.0, 0.01, 0.1, 0.25, 0.5, 0.75, 0.9, 0.99, 0.999, 1.0}) {
    const double exact = exactPercentile(samples, q);
    EXPECT_NEAR(h.percentile(q), exact, 0.005 * exact) << "q " << q;
  }
  // The extremes are exact (clamped to the smallest and largest sample).
  EXPECT_EQ(h.percentile(0.0), h.min());
  EXPECT_EQ(h.percentile(1.0), h.max());
}

TEST(LatencyHistogram, OneSampleIsExactAndOutOfRangeValuesAreKept) {
  LatencyHistogram one;
  one.add(12.345);
  EXPECT_EQ(one.percentile(0.5), 12.345);
  EXPECT_EQ(one.percentile(0.99), 12.345);

  LatencyHistogram extremes;
  extremes.add(0.0);           // below the first bin
  extremes.add(5e9);           // beyond the last one
  extremes.add(std::nan(""));  // not counted
  EXPECT_EQ(extremes.count(), 2u);
  EXPECT_EQ(extremes.percentile(0.5), 0.0);
  EXPECT_EQ(extremes.percentile(1.0), 5e9);
}

}  // namespace
}  // namespace vims
