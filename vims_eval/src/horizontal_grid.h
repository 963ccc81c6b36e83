#pragma once
/// @file horizontal_grid.h
/// @brief A horizontal hash grid of trajectory samples (internal to vims_eval): the revisit
/// events and the relocalisation's "entered the map" both ask whether a point lies within a
/// radius of earlier samples.

#include <Eigen/Core>
#include <cmath>
#include <optional>
#include <unordered_map>
#include <vector>

#include "vims_common/trajectory_io.h"

namespace vims {
namespace eval {

/// Horizontal hash grid of ground-truth sample indices, cell size = search radius, so a
/// radius query only visits the 3x3 cells around the query point.
class HorizontalGrid {
 public:
  explicit HorizontalGrid(double cell_m) : cell_m_(cell_m) {}

  void insert(const Eigen::Vector3d& p_w, std::size_t index) {
    cells_[key(cellOf(p_w.x()), cellOf(p_w.y()))].push_back(index);
  }

  /// Any inserted index within radius_m (horizontally) of p_w, or nullopt.
  std::optional<std::size_t> findWithin(const Eigen::Vector3d& p_w, double radius_m,
                                        const std::vector<StampedPose>& poses) const {
    const long cx = cellOf(p_w.x());
    const long cy = cellOf(p_w.y());
    const double r2 = radius_m * radius_m;
    for (long dx = -1; dx <= 1; ++dx) {
      for (long dy = -1; dy <= 1; ++dy) {
        const auto it = cells_.find(key(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (std::size_t j : it->second)
          if ((poses[j].p.head<2>() - p_w.head<2>()).squaredNorm() <= r2) return j;
      }
    }
    return std::nullopt;
  }

 private:
  long cellOf(double v) const { return static_cast<long>(std::floor(v / cell_m_)); }
  static long long key(long cx, long cy) {
    // Cells are bounded by |position| / radius, far below 2^31 for any real survey.
    return (static_cast<long long>(cx) << 32) ^ static_cast<long long>(static_cast<unsigned int>(cy));
  }

  double cell_m_;
  std::unordered_map<long long, std::vector<std::size_t>> cells_;
};

}  // namespace eval
}  // namespace vims
