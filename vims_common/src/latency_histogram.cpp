#include "vims_common/latency_histogram.h"

#include <algorithm>
#include <cmath>

namespace vims {

namespace {
constexpr double kSmallestMs = 1e-6;  // 1 ns: below the resolution of the clocks used
constexpr double kLargestMs = 1e7;    // ~2.8 h: a stage never takes longer; beyond counts in the last bin
const double kLogBinWidth = std::log1p(LatencyHistogram::kRelativeBinWidth);
}  // namespace

LatencyHistogram::LatencyHistogram()
    : bins_(static_cast<std::size_t>(std::ceil(std::log(kLargestMs / kSmallestMs) / kLogBinWidth)) + 1, 0) {}

std::size_t LatencyHistogram::binOf(double ms) const {
  if (!(ms > kSmallestMs)) return 0;
  const double i = std::floor(std::log(ms / kSmallestMs) / kLogBinWidth);
  return std::min(bins_.size() - 1, static_cast<std::size_t>(i));
}

double LatencyHistogram::representative(std::size_t i) const {
  return kSmallestMs * std::exp((static_cast<double>(i) + (i == 0 ? 0.0 : 0.5)) * kLogBinWidth);
}

void LatencyHistogram::add(double ms) {
  if (std::isnan(ms)) return;
  ++bins_[binOf(ms)];
  min_ = count_ == 0 ? ms : std::min(min_, ms);
  max_ = count_ == 0 ? ms : std::max(max_, ms);
  ++count_;
  sum_ += ms;
}

double LatencyHistogram::min() const { return min_; }
double LatencyHistogram::max() const { return max_; }

double LatencyHistogram::percentile(double q) const {
  if (count_ == 0) return 0.0;
  q = std::clamp(q, 0.0, 1.0);
  // The same rank as the exact nearest-rank percentile of the sorted samples (1-based).
  const auto rank = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(q * static_cast<double>(count_))));
  if (rank == 1) return min_;
  if (rank >= count_) return max_;
  std::size_t seen = 0;
  for (std::size_t i = 0; i < bins_.size(); ++i) {
    seen += bins_[i];
    if (seen >= rank) return std::clamp(representative(i), min_, max_);
  }
  return max_;
}

}  // namespace vims
