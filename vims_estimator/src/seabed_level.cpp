#include "vims_estimator/seabed_level.h"

#include <algorithm>
#include <cmath>

namespace vims {

double seabedLevelRadius(double flatness_std, double slope_random_walk, double max_radius) {
  if (!(flatness_std > 0.0)) return 0.0;
  if (!(slope_random_walk > 0.0)) return max_radius;
  return std::min(max_radius, std::cbrt(3.0 * flatness_std * flatness_std / (slope_random_walk * slope_random_walk)));
}

std::optional<SeabedLevel> seabedLevelAt(const Eigen::Vector3d& centre, const Eigen::Vector2d& slope,
                                         const std::vector<Eigen::Vector3d>& hits, double radius,
                                         double outlier_threshold) {
  struct Carried {
    double value;
    double weight;
  };
  std::vector<Carried> carried;
  carried.reserve(hits.size());
  for (const Eigen::Vector3d& hit : hits) {
    if (!hit.allFinite()) continue;
    const Eigen::Vector2d offset = centre.head<2>() - hit.head<2>();
    const double distance = offset.norm();
    if (!(distance < radius)) continue;
    carried.push_back({hit.z() + slope.dot(offset), 1.0 - distance / radius});
  }
  if (carried.empty()) return std::nullopt;
  std::vector<double> values;
  values.reserve(carried.size());
  for (const Carried& c : carried) values.push_back(c.value);
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  const double median = *middle;
  double sum = 0.0, weights = 0.0;
  SeabedLevel level;
  for (const Carried& c : carried) {
    if (std::abs(c.value - median) > outlier_threshold) continue;
    sum += c.weight * c.value;
    weights += c.weight;
    ++level.hits;
  }
  if (!(weights > 0.0)) return std::nullopt;
  level.height = sum / weights;
  return level;
}

void SeabedHitHistory::add(const Eigen::Vector3d& hit) {
  if (!hit.allFinite()) return;
  hits_.push_back(hit);
  while (hits_.size() > max_hits_) hits_.pop_front();
}

void SeabedHitHistory::prune(const Eigen::Vector2d& newest) {
  const double reach = 2.0 * radius_;
  hits_.erase(std::remove_if(hits_.begin(), hits_.end(),
                             [&](const Eigen::Vector3d& h) { return (h.head<2>() - newest).norm() > reach; }),
              hits_.end());
}

}  // namespace vims
