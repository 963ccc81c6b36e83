/// @file guided_matching.cpp
/// @brief Relocalisation's guided matching: matchPointsByProjection (a query's points matched
/// with a candidate's keypoints near where a pose hypothesis projects them) and the
/// LoopVerifier's levelled, widened pose (docs/pose_graph.md, "Relocalisation: guided matching").

#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "point_keypoint_distance.h"
#include "vims_pose_graph/loop_detector.h"
#include "vims_pose_graph/loop_measurement.h"

namespace vims {

std::vector<PointMatch> matchPointsByProjection(const DescribedPoints& points, const VisualSubmap& candidate,
                                                const CameraModel& camera, const Eigen::Isometry3d& T_c_odom,
                                                double radius_px, double ratio, int max_distance,
                                                double duplicate_radius_px, const LevelWindow& levels) {
  std::vector<PointMatch> matches;
  const size_t num_keypoints = candidate.keypoints.size();
  if (points.empty() || num_keypoints == 0 || candidate.descriptors.size() != num_keypoints) return matches;
  const std::vector<std::vector<uint32_t>> by_point = descriptorsByPoint(points);
  const double radius2 = radius_px * radius_px;
  const double duplicate_r2 = duplicate_radius_px * duplicate_radius_px;
  for (uint32_t p = 0; p < by_point.size(); ++p) {
    if (by_point[p].empty()) continue;
    const std::optional<Eigen::Vector2d> uv = camera.project(T_c_odom * points.p_odom[p]);
    if (!uv || uv->x() < 0.0 || uv->y() < 0.0 || uv->x() >= camera.width() || uv->y() >= camera.height()) continue;
    // The keypoints in the window, with their distances: a few dozen at most.
    int best = 257;
    size_t best_k = num_keypoints;
    std::vector<std::pair<size_t, int>> near;
    for (size_t k = 0; k < num_keypoints; ++k) {
      const double dx = candidate.keypoints[k].pt.x - uv->x();
      const double dy = candidate.keypoints[k].pt.y - uv->y();
      if (dx * dx + dy * dy > radius2) continue;
      const int d = pointDistance(points, by_point[p], candidate.descriptors[k], candidate.keypoints[k].octave, levels);
      near.emplace_back(k, d);
      if (d < best) {
        best = d;
        best_k = k;
      }
    }
    if (best_k == num_keypoints || best > max_distance) continue;
    int second = 257;
    const cv::Point2f& at = candidate.keypoints[best_k].pt;
    for (const auto& [k, d] : near) {
      if (k == best_k || d >= second) continue;
      const cv::Point2f offset = candidate.keypoints[k].pt - at;
      if (static_cast<double>(offset.x) * offset.x + static_cast<double>(offset.y) * offset.y <= duplicate_r2) continue;
      second = d;
    }
    if (ratio < 1.0 && !(best < ratio * second)) continue;
    matches.push_back(PointMatch{p, static_cast<uint32_t>(best_k), best});
  }
  return closestMatchPerKeypoint(matches, num_keypoints);
}

std::optional<Eigen::Isometry3d> LoopVerifier::levelledPose(const LoopQuery& query, const DescribedPoints& points,
                                                            const VisualSubmap& sub, const MapNode& cand,
                                                            const Eigen::Isometry3d& T_bm_cm,
                                                            const Eigen::Isometry3d& T_c_odom,
                                                            const std::vector<PointMatch>& matches) const {
  LoopInlierGeometry geometry;
  for (const auto& [point, keypoint] : inliersUnder(points, matches, sub, T_c_odom)) {
    geometry.points_odom_query.push_back(points.p_odom[point]);
    geometry.normalized_match.push_back(sub.normalized[keypoint]);
  }
  if (static_cast<int>(geometry.points_odom_query.size()) < options_.guided_min_inliers) return std::nullopt;
  const std::optional<LoopMeasurement> levelled = refineLoopMeasurement(
      geometry, T_bm_cm * T_c_odom * query.T_odom_b, query.T_odom_b, T_bm_cm, cand.pose.pitch, cand.pose.roll);
  if (!levelled) return std::nullopt;
  return T_bm_cm.inverse() * levelled->T_match_query * query.T_odom_b.inverse();
}

std::optional<Eigen::Isometry3d> LoopVerifier::guidedPose(const LoopQuery& query, const DescribedPoints& points,
                                                          const VisualSubmap& sub, const MapNode& cand,
                                                          const Eigen::Isometry3d& T_bm_cm,
                                                          const Eigen::Isometry3d& T_c_odom, const LevelWindow& levels,
                                                          std::vector<PointMatch>* matches) const {
  // The hypothesis levelled first: a weak or partial-view consensus (a revisit to the side)
  // trades tilt for position, and its 6-DoF pose can be several degrees and decimetres off.
  std::optional<Eigen::Isometry3d> pose = levelledPose(query, points, sub, cand, T_bm_cm, T_c_odom, *matches);
  if (!pose) return std::nullopt;
  *matches = matchNear(points, sub, *pose, levels);
  return levelledOnMatches(query, points, sub, cand, T_bm_cm, *pose, *matches);
}

std::vector<PointMatch> LoopVerifier::matchNear(const DescribedPoints& points, const VisualSubmap& sub,
                                                const Eigen::Isometry3d& T_c_odom, const LevelWindow& levels) const {
  return matchPointsByProjection(points, sub, camera_model_, T_c_odom, options_.guided_search_radius_px,
                                 options_.match_ratio, options_.match_max_distance, options_.match_duplicate_radius_px,
                                 levels);
}

std::optional<Eigen::Isometry3d> LoopVerifier::levelledOnMatches(const LoopQuery& query, const DescribedPoints& points,
                                                                 const VisualSubmap& sub, const MapNode& cand,
                                                                 const Eigen::Isometry3d& T_bm_cm,
                                                                 const Eigen::Isometry3d& T_c_odom,
                                                                 const std::vector<PointMatch>& matches) const {
  // Twice: the search radius is wider than the inlier threshold, and the pose fitted on the
  // first inliers explains the matches near the image's edge better.
  std::optional<Eigen::Isometry3d> pose = T_c_odom;
  for (int round = 0; round < 2 && pose; ++round)
    pose = levelledPose(query, points, sub, cand, T_bm_cm, *pose, matches);
  return pose;
}

}  // namespace vims
