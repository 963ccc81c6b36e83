#pragma once
/// @file odometry_drift.h
/// @brief The VIO's own drift, learnt from the loops: how much the sequential (odometry) edges
/// of the pose graph should be trusted (docs/pose_graph.md, "Odometry drift learnt from the
/// loops").
///
/// A sequential edge's sigmas follow the configured shape (PoseGraphOptions: a floor plus a
/// growth with the distance between the keyframes). What the shape cannot know is the size of
/// this VIO's drift on this mission. Every verified loop measures it: the loop's relative pose
/// against the composition of the odometry edges from the match to the query is the drift the
/// chain accumulated, plus the loop's own error. The fit finds the two variance multipliers,
/// for the edges' position and their yaw, under which these discrepancies are most likely
/// (a Gaussian likelihood over the loops' chains, the chains' shared edges correlated exactly),
/// and the graph weighs every sequential edge of the run with them.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "vims_pose_graph/pose_graph.h"

namespace vims {

/// Variance multipliers of the sequential edges (1 = the configured sigmas).
struct OdometryDriftScale {
  double position = 1.0;
  double yaw = 1.0;
};

/// The square-root information (1/sigma_x, 1/sigma_y, 1/sigma_z, 1/sigma_yaw) of a sequential
/// edge with measurement `z`: the configured shape sigma(d) = sqrt(sigma_0^2 + (sigma_per_m d)^2)
/// for position and yaw, d = |z.p_li_j|, each variance multiplied by `scale`.
Eigen::Vector4d sequentialEdgeSqrtInformation(const PoseGraphOptions& options, const RelativePose4Dof& z,
                                              const OdometryDriftScale& scale = OdometryDriftScale());

struct OdometryDriftFit {
  bool fitted = false;  ///< false: too few usable chains (scale is then 1, 1)
  OdometryDriftScale scale;
  size_t loops_with_chain = 0;       ///< loops whose match and query one odometry chain joins
  size_t chains_used = 0;            ///< of those, the distinct chains in the fit
  size_t chains_rejected = 0;        ///< distinct chains left out as outliers (a wrong loop)
  double mean_chain_length_m = 0.0;  ///< path length of the chains used
};

/// Fits the drift from the loops. `odometry_edges` are the sequential edges whose two nodes share one VIO frame (no
/// session links; the chains are composed from their VIO measurements), `loops` the loop edges (disabled ones are
/// skipped). A loop counts when a chain of odometry edges leads from its match to its query; loops whose chains share
/// more than 90 % of the longer chain's edges are one event and only the first is used (the others repeat the same
/// drift with the loop noise on top). Robust to wrong loops: the chains within the chi-square
/// 99.9 % bound under the median of the single chains' fits are fitted jointly, every chain is
/// tested again under that fit and a changed set fitted once more. Fewer than
/// options.odometry_drift_min_chains chains (or inliers): not fitted. The multipliers stay
/// within [odometry_drift_scale_min, odometry_drift_scale_max].
OdometryDriftFit fitOdometryDrift(const std::vector<SequentialEdge>& odometry_edges, const std::vector<LoopEdge>& loops,
                                  const PoseGraphOptions& options);

/// fitOdometryDrift as a run goes on: re-fits only when the loops bring a chain of a new
/// revisit event (the loops of one event repeat its chain; the fit is the costly part).
class OdometryDriftEstimator {
 public:
  explicit OdometryDriftEstimator(const PoseGraphOptions& options) : options_(options) {}
  const OdometryDriftFit& update(const std::vector<SequentialEdge>& odometry_edges, const std::vector<LoopEdge>& loops);
  const OdometryDriftFit& fit() const { return fit_; }

 private:
  PoseGraphOptions options_;
  std::vector<LoopEdgeId> chain_loops_;  ///< the loops of the chains of the last fit
  OdometryDriftFit fit_;
};

}  // namespace vims
