// timing.h: the percentile's convention and the clocks' units.
#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "vims_common/timing.h"

namespace vims {
namespace {

TEST(Timing, PercentileIsTheSortedValueAtTheRoundedIndex) {
  const std::vector<double> v = {5.0, 1.0, 4.0, 2.0, 3.0};
  EXPECT_DOUBLE_EQ(percentile(v, 0.5), 3.0);
  EXPECT_DOUBLE_EQ(percentile(v, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(percentile(v, 1.0), 5.0);
  EXPECT_DOUBLE_EQ(percentile(v, 0.99), 5.0);          // index round(3.96) = 4
  EXPECT_DOUBLE_EQ(percentile({1.0, 2.0}, 0.5), 2.0);  // even n: the upper middle value
  EXPECT_DOUBLE_EQ(percentile(v, 7.0), 5.0);           // q outside [0, 1] is clamped
  EXPECT_TRUE(std::isnan(percentile({}, 0.5)));
}

TEST(Timing, ClocksCountMillisecondsAndThreadCpuSeconds) {
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = threadCpuSeconds();
  volatile double sink = 0.0;
  for (int i = 0; i < 2000000; ++i) sink = sink + std::sqrt(static_cast<double>(i));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const double cpu = threadCpuSeconds() - cpu_start;
  EXPECT_GE(millisecondsSince(start), 20.0);        // the sleep alone is 20 ms of wall time
  EXPECT_GT(cpu, 0.0);                              // the loop used CPU ...
  EXPECT_LT(cpu, 1e-3 * millisecondsSince(start));  // ... but none while asleep
}

}  // namespace
}  // namespace vims
