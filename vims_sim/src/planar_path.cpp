#include "vims_sim/planar_path.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "vims_common/wrap_angle.h"

namespace vims {
namespace sim {

void PlanarPath::append(double length, double curvature) {
  if (length <= 0.0) return;
  Piece piece;
  piece.s0 = length_;
  piece.length = length;
  piece.start = end_;
  piece.heading0 = end_heading_;
  piece.curvature = curvature;
  pieces_.push_back(piece);
  length_ += length;
  // Advance the end state with the exact piece geometry so the next piece starts where this ends.
  const Point end = at(length_);
  end_ = end.position;
  end_heading_ = end.heading;
}

PlanarPath PlanarPath::roundedPolyline(const std::vector<Eigen::Vector2d>& waypoints, double corner_radius) {
  std::vector<Eigen::Vector2d> w;
  for (const auto& p : waypoints)
    if (w.empty() || (p - w.back()).norm() > 1e-9) w.push_back(p);
  if (w.size() < 2) throw std::invalid_argument("PlanarPath: needs at least two distinct waypoints");
  if (!(corner_radius > 0.0)) throw std::invalid_argument("PlanarPath: corner radius must be > 0");

  const size_t n = w.size();
  std::vector<double> seg_len(n - 1), seg_heading(n - 1);
  for (size_t i = 0; i + 1 < n; ++i) {
    const Eigen::Vector2d d = w[i + 1] - w[i];
    seg_len[i] = d.norm();
    seg_heading[i] = std::atan2(d.y(), d.x());
  }
  // Tangent length of each interior corner (0 at the ends): at most half of each neighbouring
  // segment, so the arcs of two consecutive corners never overlap.
  std::vector<double> tangent(n, 0.0), turn(n, 0.0);
  for (size_t i = 1; i + 1 < n; ++i) {
    turn[i] = wrapAngle(seg_heading[i] - seg_heading[i - 1]);
    const double half = std::abs(turn[i]) * 0.5;
    if (half < 1e-9) continue;
    const double wanted = corner_radius * std::tan(half);
    tangent[i] = std::min({wanted, 0.5 * seg_len[i - 1], 0.5 * seg_len[i]});
  }

  PlanarPath path;
  path.end_ = w[0];
  path.end_heading_ = seg_heading[0];
  for (size_t i = 0; i + 1 < n; ++i) {
    // Straight part of segment i, from the end of the previous arc to the start of the next.
    const double straight = seg_len[i] - tangent[i] - tangent[i + 1];
    path.append(straight, 0.0);
    if (i + 1 < n - 1 && tangent[i + 1] > 0.0) {
      const double half = std::abs(turn[i + 1]) * 0.5;
      const double radius = tangent[i + 1] / std::tan(half);
      const double sign = turn[i + 1] > 0.0 ? 1.0 : -1.0;
      path.append(radius * std::abs(turn[i + 1]), sign / radius);
    }
  }
  return path;
}

PlanarPath::Point PlanarPath::at(double s) const {
  Point p;
  if (pieces_.empty()) {
    p.position = end_;
    p.heading = end_heading_;
    return p;
  }
  s = std::clamp(s, 0.0, length_);
  auto it = std::upper_bound(pieces_.begin(), pieces_.end(), s,
                             [](double value, const Piece& piece) { return value < piece.s0; });
  const Piece& piece = *(it == pieces_.begin() ? it : std::prev(it));
  const double sigma = std::min(s - piece.s0, piece.length);
  const double h0 = piece.heading0;
  p.curvature = piece.curvature;
  p.heading = h0 + piece.curvature * sigma;
  if (std::abs(piece.curvature) < 1e-12) {
    p.position = piece.start + sigma * Eigen::Vector2d(std::cos(h0), std::sin(h0));
  } else {
    const double k = piece.curvature;
    p.position =
        piece.start + Eigen::Vector2d(std::sin(p.heading) - std::sin(h0), -(std::cos(p.heading) - std::cos(h0))) / k;
  }
  return p;
}

}  // namespace sim
}  // namespace vims
