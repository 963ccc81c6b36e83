#pragma once
/// @file known_vertical_pose.h
/// @brief Absolute camera pose from 2D-3D matches when the camera's tilt is known: the minimal
/// 2-point solver and a RANSAC consensus count built on it (the loop verifier's cheap test of
/// whether a PnP consensus can exist at all).
///
/// Both VIO frames of a loop are gravity-aligned, so the candidate camera's attitude in the
/// query's VIO frame is known up to a rotation about the vertical: R = Rz(yaw) A, with A the
/// candidate camera's attitude in its own VIO frame. Four unknowns (yaw and the camera centre)
/// need two matches instead of the three (plus one to choose) of P3P, so a clean sample at an
/// inlier rate w comes after ~1/w^2 samples instead of ~1/w^4: at the 10-30 % inlier rates of
/// rejected loop candidates, 20-100 times fewer hypotheses to rule a consensus out.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace vims {

/// A camera pose in the points' frame: x_cam = R^T (p - centre).
struct VerticalPoseHypothesis {
  double yaw = 0.0;  ///< rotation about the points' frame z axis applied to the known attitude [rad]
  Eigen::Matrix3d R_points_cam = Eigen::Matrix3d::Identity();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
};

/// Minimal solver. `p1`, `p2`: two 3D points (a frame whose z axis is vertical); `x1`, `x2`: their
/// normalised image coordinates; `A`: the camera's attitude up to a yaw (R_points_cam = Rz(yaw) A).
/// Solution (docs/pose_graph.md, "Known-vertical consensus"): with bearings d_i = A [x_i; 1]
/// and u_i = Rz(yaw) d_i, p_i = c + l_i u_i, so p1 - p2 lies in the plane of u1 and u2:
///   (p1 - p2) . Rz(yaw) (d1 x d2) = 0,  i.e.  a cos(yaw) + b sin(yaw) = -k,
/// one equation in the yaw with up to two roots; each gives l_1, l_2 by least squares and the
/// centre. Hypotheses with a point behind the camera are dropped. Returns 0-2 hypotheses.
std::vector<VerticalPoseHypothesis> solveKnownVerticalPose(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                                                           const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
                                                           const Eigen::Matrix3d& A);

/// Number of matches (points[i], normalized[i]) that reproject within `threshold` (normalised
/// units) in front of the camera under `pose`.
int countInliers(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector2d>& normalized,
                 const VerticalPoseHypothesis& pose, double threshold);

/// The largest consensus RANSAC finds with the 2-point solver in `iterations` samples (a fixed
/// seed: deterministic). Stops early once `enough` inliers are found.
struct KnownVerticalConsensus {
  int inliers = 0;
  int samples = 0;  ///< samples drawn
};
KnownVerticalConsensus knownVerticalConsensus(const std::vector<Eigen::Vector3d>& points,
                                              const std::vector<Eigen::Vector2d>& normalized, const Eigen::Matrix3d& A,
                                              double threshold, int iterations, int enough,
                                              std::uint32_t seed = 0x5eed);

/// Samples that suffice to rule out a consensus of `min_inliers` among `num_matches` with a
/// `sample_size`-point solver at `confidence`: k = log(1 - confidence) / log(1 - w^n) with
/// w = min_inliers / num_matches, taken three times because a clean sample of noisy points does
/// not always give a model whose consensus reaches the whole inlier set.
int ransacIterationsToReject(std::size_t num_matches, int min_inliers, double confidence, int sample_size);

}  // namespace vims
