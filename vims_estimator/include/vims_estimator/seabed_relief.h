#pragma once
/// @file seabed_relief.h
/// @brief How rough the seabed is at the scale of the camera's footprint, learnt from the
/// sonar's own hits (docs/factors.md 5e).
///
/// A sonar depth factor compares a feature with the plane through its anchor's beam hit. What no
/// plane follows (hummocks, hollows, boulders half-buried) makes that comparison err by
///
///   e(D) = b(x_f) - b(x_hit),   Var e(D) = 2 gamma(D)
///
/// with b the seabed's deviation from the plane and gamma its semivariogram at the horizontal
/// distance D between the feature and the hit. The sonar samples the same seabed along the
/// track: two hits i, j a distance d apart, with the mean gradient g of their keyframes, give
///
///   r_ij = (h_j - h_i) - g . (xy_j - xy_i),   E r_ij^2 = 2 sigma_s^2 + m^2 d^2
///
/// (sigma_s: the factor's sonar sigma, range noise and flatness; m: the growth of the misfit's
/// standard deviation per metre, the linear model 2 gamma(D) = m^2 D^2). m is the value for
/// which the median of z_ij^2 = r_ij^2 / (2 sigma_s^2 + m^2 d^2) over the pairs equals the
/// median of chi-square with one degree of freedom (0.455): a median, so a rock or a fish under
/// one ping does not move it, and 0 when the pairs are no further apart than the noise explains
/// (a flat tank floor). Only pairs at the distances the features have from their hits count
/// (an octave either side of their median distance): that is where the factor uses m.

#include <Eigen/Core>
#include <deque>
#include <optional>
#include <utility>
#include <vector>

namespace vims {

/// One sonar hit on the seabed in the gravity-aligned frame l.
struct SeabedSample {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();     ///< horizontal position of the hit [m]
  double height = 0.0;                              ///< its height [m]
  Eigen::Vector2d slope = Eigen::Vector2d::Zero();  ///< seabed gradient of its keyframe
};

/// The learnt misfit m and what it rests on.
struct SeabedReliefEstimate {
  double misfit_per_m = 0.0;
  int pairs = 0;                 ///< pairs of hits at the features' distances
  double pair_distance_m = 0.0;  ///< the features' median distance from their hits
};

/// The hits that left the sliding window (a bounded history, oldest dropped first) and the
/// estimate of m from them together with the window's own hits.
class SeabedRelief {
 public:
  explicit SeabedRelief(std::size_t history_hits) : history_hits_(history_hits) {}

  /// A hit whose keyframe left the window (its pose is as good as it will get).
  void addHistory(const SeabedSample& sample);
  /// A new session has a new frame l: the history means nothing there.
  void clear() { history_.clear(); }
  std::size_t historySize() const { return history_.size(); }
  /// The kept hit horizontally nearest to `xy` if it is nearer than `within` [m] (the index into
  /// the kept hits, oldest first, and its distance); what SonarDepthOptions::tie_to_nearest_hit
  /// ties a feature to when it is nearer than the anchor's own hit.
  std::optional<std::pair<std::size_t, double>> nearestKeptHit(const Eigen::Vector2d& xy, double within) const;
  const SeabedSample& keptHit(std::size_t index) const { return history_.at(index); }

  /// m from the history and `window` (the window's hits at the current estimate); `sonar_sigma`
  /// is the factor's sonar sigma, `feature_distance_m` the median horizontal distance of the
  /// window's sonar-tied features from their hits. nullopt without `min_pairs` usable pairs.
  std::optional<SeabedReliefEstimate> estimate(const std::vector<SeabedSample>& window, double sonar_sigma,
                                               double feature_distance_m, int min_pairs) const;

 private:
  std::size_t history_hits_;
  std::deque<SeabedSample> history_;
};

/// The median of chi-square with one degree of freedom.
inline constexpr double kChi2OneDofMedian = 0.45493642311957283;

/// The m solving median_ij(r_ij^2 / (2 s^2 + m^2 d_ij^2)) = kChi2OneDofMedian for pair residuals
/// r and distances d (same length, d > 0), s = sonar_sigma; 0 when m = 0 already gives a median at
/// or below it. Exposed for the tests.
double misfitFromPairs(const std::vector<double>& residuals, const std::vector<double>& distances, double sonar_sigma);

}  // namespace vims
