#include "vims_estimator/seabed_relief.h"

#include <algorithm>
#include <cmath>

namespace vims {
namespace {

double medianWhitened(const std::vector<double>& r2, const std::vector<double>& d2, double two_s2, double m,
                      std::vector<double>* scratch) {
  scratch->resize(r2.size());
  for (std::size_t i = 0; i < r2.size(); ++i) (*scratch)[i] = r2[i] / (two_s2 + m * m * d2[i]);
  const auto mid = scratch->begin() + static_cast<std::ptrdiff_t>(scratch->size() / 2);
  std::nth_element(scratch->begin(), mid, scratch->end());
  return *mid;
}

}  // namespace

void SeabedRelief::addHistory(const SeabedSample& sample) {
  if (!std::isfinite(sample.height) || !sample.xy.allFinite() || !sample.slope.allFinite()) return;
  history_.push_back(sample);
  while (history_.size() > history_hits_) history_.pop_front();
}

std::optional<std::pair<std::size_t, double>> SeabedRelief::nearestKeptHit(const Eigen::Vector2d& xy,
                                                                           double within) const {
  std::optional<std::pair<std::size_t, double>> nearest;
  double best = within;
  for (std::size_t k = 0; k < history_.size(); ++k) {
    const double d = (history_[k].xy - xy).norm();
    if (d < best) {
      best = d;
      nearest = std::make_pair(k, d);
    }
  }
  return nearest;
}

double misfitFromPairs(const std::vector<double>& residuals, const std::vector<double>& distances, double sonar_sigma) {
  if (residuals.empty() || residuals.size() != distances.size()) return 0.0;
  std::vector<double> r2(residuals.size()), d2(distances.size()), scratch;
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    r2[i] = residuals[i] * residuals[i];
    d2[i] = distances[i] * distances[i];
  }
  // A zero sonar sigma (an ideal simulation without flatness) would make m = 0 infinitely strict.
  const double two_s2 = std::max(2.0 * sonar_sigma * sonar_sigma, 1e-12);
  if (medianWhitened(r2, d2, two_s2, 0.0, &scratch) <= kChi2OneDofMedian) return 0.0;
  // The median of z^2 falls monotonically with m: bracket, then bisect to 0.1 % of m.
  double lo = 0.0, hi = 0.01;
  while (medianWhitened(r2, d2, two_s2, hi, &scratch) > kChi2OneDofMedian) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e3) return hi;  // residuals without bound: no plane-like seabed at all
  }
  while (hi - lo > 1e-3 * hi) {
    const double mid = 0.5 * (lo + hi);
    (medianWhitened(r2, d2, two_s2, mid, &scratch) > kChi2OneDofMedian ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

std::optional<SeabedReliefEstimate> SeabedRelief::estimate(const std::vector<SeabedSample>& window, double sonar_sigma,
                                                           double feature_distance_m, int min_pairs) const {
  if (!(feature_distance_m > 0.0)) return std::nullopt;
  std::vector<const SeabedSample*> samples;
  samples.reserve(history_.size() + window.size());
  for (const auto& s : history_) samples.push_back(&s);
  for (const auto& s : window)
    if (std::isfinite(s.height) && s.xy.allFinite() && s.slope.allFinite()) samples.push_back(&s);
  const double d_min = 0.5 * feature_distance_m, d_max = 2.0 * feature_distance_m;
  std::vector<double> residuals, distances;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    for (std::size_t j = i + 1; j < samples.size(); ++j) {
      const Eigen::Vector2d dxy = samples[j]->xy - samples[i]->xy;
      const double d = dxy.norm();
      if (d < d_min || d > d_max) continue;
      const Eigen::Vector2d slope = 0.5 * (samples[i]->slope + samples[j]->slope);
      residuals.push_back(samples[j]->height - samples[i]->height - slope.dot(dxy));
      distances.push_back(d);
    }
  }
  if (static_cast<int>(residuals.size()) < min_pairs) return std::nullopt;
  SeabedReliefEstimate e;
  e.misfit_per_m = misfitFromPairs(residuals, distances, sonar_sigma);
  e.pairs = static_cast<int>(residuals.size());
  e.pair_distance_m = feature_distance_m;
  return e;
}

}  // namespace vims
