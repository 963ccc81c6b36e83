#include "vims_pose_graph/known_vertical_pose.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace vims {

namespace {

Eigen::Matrix3d rotationZ(double yaw) { return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix(); }

}  // namespace

std::vector<VerticalPoseHypothesis> solveKnownVerticalPose(const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                                                           const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
                                                           const Eigen::Matrix3d& A) {
  std::vector<VerticalPoseHypothesis> out;
  const Eigen::Vector3d d1 = A * x1.homogeneous();
  const Eigen::Vector3d d2 = A * x2.homogeneous();
  const Eigen::Vector3d n = d1.cross(d2);
  const Eigen::Vector3d delta = p1 - p2;
  // delta . Rz(yaw) n = cos(yaw) (dx nx + dy ny) + sin(yaw) (dy nx - dx ny) + dz nz = 0.
  const double a = delta.x() * n.x() + delta.y() * n.y();
  const double b = delta.y() * n.x() - delta.x() * n.y();
  const double k = delta.z() * n.z();
  const double r = std::hypot(a, b);
  // Parallel bearings or coincident points: no (or no unique) solution.
  if (!(r > 1e-12 * delta.norm() * n.norm()) || std::abs(k) > r) return out;
  const double phase = std::atan2(b, a);
  const double spread = std::acos(std::clamp(-k / r, -1.0, 1.0));
  for (double yaw : {phase + spread, phase - spread}) {
    if (!out.empty() && spread < 1e-12) break;  // a double root
    VerticalPoseHypothesis h;
    h.yaw = std::remainder(yaw, 2.0 * M_PI);
    const Eigen::Matrix3d Rz = rotationZ(h.yaw);
    const Eigen::Vector3d u1 = Rz * d1;
    const Eigen::Vector3d u2 = Rz * d2;
    // delta = l1 u1 - l2 u2 (exactly solvable now): least squares on the 3x2 system.
    Eigen::Matrix<double, 3, 2> M;
    M.col(0) = u1;
    M.col(1) = -u2;
    const Eigen::Vector2d l = (M.transpose() * M).ldlt().solve(M.transpose() * delta);
    if (!(l.x() > 0.0) || !(l.y() > 0.0) || !l.allFinite()) continue;  // a point behind the camera
    h.R_points_cam = Rz * A;
    h.centre = p1 - l.x() * u1;
    out.push_back(h);
  }
  return out;
}

int countInliers(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector2d>& normalized,
                 const VerticalPoseHypothesis& pose, double threshold) {
  const Eigen::Matrix3d R_cam_points = pose.R_points_cam.transpose();
  const Eigen::Vector3d t_cam_points = -R_cam_points * pose.centre;
  const double threshold2 = threshold * threshold;
  int inliers = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = R_cam_points * points[i] + t_cam_points;
    if (!(p.z() > 0.0)) continue;
    // |p.xy / p.z - x| <= threshold without the division.
    const Eigen::Vector2d e = p.head<2>() - p.z() * normalized[i];
    if (e.squaredNorm() <= threshold2 * p.z() * p.z()) ++inliers;
  }
  return inliers;
}

KnownVerticalConsensus knownVerticalConsensus(const std::vector<Eigen::Vector3d>& points,
                                              const std::vector<Eigen::Vector2d>& normalized, const Eigen::Matrix3d& A,
                                              double threshold, int iterations, int enough, std::uint32_t seed) {
  KnownVerticalConsensus result;
  const std::size_t n = std::min(points.size(), normalized.size());
  if (n < 2) return result;
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, n - 1);
  for (int it = 0; it < iterations && result.inliers < enough; ++it) {
    const std::size_t i = pick(rng);
    std::size_t j = pick(rng);
    if (i == j) j = (j + 1) % n;
    ++result.samples;
    for (const VerticalPoseHypothesis& h :
         solveKnownVerticalPose(points[i], points[j], normalized[i], normalized[j], A))
      result.inliers = std::max(result.inliers, countInliers(points, normalized, h, threshold));
  }
  return result;
}

int ransacIterationsToReject(std::size_t num_matches, int min_inliers, double confidence, int sample_size) {
  if (num_matches == 0) return 1;
  const double w = std::min(1.0, static_cast<double>(min_inliers) / static_cast<double>(num_matches));
  const double clean = std::pow(w, sample_size);
  if (clean >= 1.0) return 1;
  const double k = std::log(1.0 - confidence) / std::log(1.0 - clean);
  return static_cast<int>(std::min(1e9, std::ceil(3.0 * k)));
}

}  // namespace vims
