#pragma once
/// @file seabed_level.h
/// @brief The smooth seabed's height under a sonar hit, from the hits around it (seabed model
/// local_plane, docs/factors.md 5c "Seabed level").
///
/// A single beam measures the seabed at one spot, rock, ripple or hollow included. Tying every
/// feature of keyframe k to the plane through k's own hit gives all of them the same error (the
/// roughness under that hit), which no number of features averages away: on a seabed rough to
/// 0.1 m it is a scale error of a few percent that wanders from keyframe to keyframe. The smooth
/// seabed is better estimated from all hits near k, each carried to k's hit along k's gradient:
///
///   v_j = z_j + g_k . (xy_k - xy_j)            (hit j seen from k's hit on k's plane)
///   level_k = sum_j w_j v_j / sum_j w_j,  w_j = 1 - |xy_j - xy_k| / R   over |xy_j - xy_k| < R
///
/// after dropping hits more than `outlier_threshold` from the median of the v_j (a rock or a fish
/// under one ping must not move its neighbours' level). The radius R is where the gradient's own
/// random walk q [1/sqrt(m)] moves the plane by as much as the seabed's flatness sigma_f:
/// q^2 R^3 / 3 = sigma_f^2 (an integrated random walk), capped at the distance over which the
/// seabed is taken to be locally a plane (SonarDepthOptions::carry_max_distance_m).

#include <Eigen/Core>
#include <deque>
#include <optional>
#include <vector>

namespace vims {

/// The height of the smooth seabed at a hit and how many hits went into it.
struct SeabedLevel {
  double height = 0.0;  ///< [m] in the gravity-aligned frame l
  int hits = 0;         ///< hits averaged (the centre's own hit included when consistent)
};

/// R = cbrt(3 flatness_std^2 / slope_random_walk^2), capped at max_radius (file comment); 0 when
/// flatness_std is 0 (a perfect plane: each hit is exact, nothing to average).
double seabedLevelRadius(double flatness_std, double slope_random_walk, double max_radius);

/// The level at the hit `centre` (x, y, z in frame l) with gradient `slope`, from `hits` (the
/// centre's own hit among them or not). Hits farther than `radius` horizontally are ignored;
/// nullopt when none is left (then the caller keeps the centre's own height).
std::optional<SeabedLevel> seabedLevelAt(const Eigen::Vector3d& centre, const Eigen::Vector2d& slope,
                                         const std::vector<Eigen::Vector3d>& hits, double radius,
                                         double outlier_threshold);

/// Hits of keyframes that left the window, kept while they can still count for a window hit:
/// those within `radius` of the newest one, at most `max_hits` (the newest).
class SeabedHitHistory {
 public:
  SeabedHitHistory(double radius, std::size_t max_hits) : radius_(radius), max_hits_(max_hits) {}
  void add(const Eigen::Vector3d& hit);
  /// Forgets hits farther than 2 radius from `newest` (horizontal): no window hit within reach.
  void prune(const Eigen::Vector2d& newest);
  void clear() { hits_.clear(); }
  const std::deque<Eigen::Vector3d>& hits() const { return hits_; }

 private:
  double radius_;
  std::size_t max_hits_;
  std::deque<Eigen::Vector3d> hits_;
};

}  // namespace vims
