#pragma once
/// @file planar_path.h
/// @brief A horizontal path made of straight lines and circular arcs, parameterised by arc
/// length: the "designed path" of an AUV survey (a polyline of waypoints with rounded corners).

#include <Eigen/Core>
#include <vector>

namespace vims {
namespace sim {

class PlanarPath {
 public:
  struct Point {
    Eigen::Vector2d position = Eigen::Vector2d::Zero();  ///< world x (east), y (north) [m]
    double heading = 0.0;    ///< direction of travel, counter-clockwise from east [rad], unwrapped
    double curvature = 0.0;  ///< signed curvature [1/m], positive when turning left
  };

  /// Polyline through `waypoints` whose corners are replaced by circular arcs of radius
  /// `corner_radius`. The radius is reduced at a corner whose neighbouring segments are too
  /// short, so the arc always fits. Consecutive duplicate waypoints are ignored.
  static PlanarPath roundedPolyline(const std::vector<Eigen::Vector2d>& waypoints, double corner_radius);

  double length() const { return length_; }
  /// The point at arc length s (clamped to [0, length()]).
  Point at(double s) const;

 private:
  struct Piece {
    double s0 = 0.0;
    double length = 0.0;
    Eigen::Vector2d start = Eigen::Vector2d::Zero();
    double heading0 = 0.0;
    double curvature = 0.0;
  };
  void append(double length, double curvature);
  std::vector<Piece> pieces_;
  double length_ = 0.0;
  Eigen::Vector2d end_ = Eigen::Vector2d::Zero();
  double end_heading_ = 0.0;
};

}  // namespace sim
}  // namespace vims
