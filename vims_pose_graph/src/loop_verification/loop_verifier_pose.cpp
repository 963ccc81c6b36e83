/// @file loop_verifier_pose.cpp
/// @brief LoopVerifier's PnP pose of a candidate: the known-vertical consensus, P3P RANSAC and
/// the LM refinement (docs/pose_graph.md, "Hierarchical place recognition and verification").

#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "vims_pose_graph/known_vertical_pose.h"
#include "vims_pose_graph/loop_detector.h"

namespace vims {

std::optional<Eigen::Isometry3d> LoopVerifier::pnpPose(const DescribedPoints& points,
                                                       const std::vector<PointMatch>& matches, const VisualSubmap& sub,
                                                       const Eigen::Matrix3d& R_odom_c, int min_inliers,
                                                       int* num_inliers) const {
  *num_inliers = 0;
  // PnP on undistorted normalised coordinates (camera matrix = identity): the query's points in
  // its VIO frame, the candidate's keypoints -> the candidate camera's pose in that frame.
  std::vector<Eigen::Vector3d> points_3d;
  std::vector<Eigen::Vector2d> normalized;
  points_3d.reserve(matches.size());
  normalized.reserve(matches.size());
  for (const PointMatch& m : matches) {
    points_3d.push_back(points.p_odom[m.point]);
    normalized.push_back(sub.normalized[m.keypoint]);
  }
  const double threshold = pnpThreshold();
  // Known-vertical test first: the candidate camera's tilt is known from its VIO attitude, so a
  // 2-point RANSAC (yaw + position) rules out a consensus of min_inliers in ~1/w^2 samples,
  // where the P3P RANSAC below needs ~1/w^4 (most candidates end at PnP). Its threshold is wider:
  // it is only a necessary condition, and a VIO tilt error that P3P would absorb adds to the
  // residuals here (docs/pose_graph.md, "Known-vertical consensus").
  if (options_.pnp_vertical_check_threshold_scale > 0.0) {
    const int samples =
        std::min(options_.pnp_iterations, ransacIterationsToReject(matches.size(), min_inliers, options_.pnp_confidence,
                                                                   /*sample_size=*/2));
    const KnownVerticalConsensus consensus = knownVerticalConsensus(
        points_3d, normalized, R_odom_c, options_.pnp_vertical_check_threshold_scale * threshold, samples, min_inliers);
    if (consensus.inliers < min_inliers) {
      *num_inliers = consensus.inliers;
      return std::nullopt;
    }
  }
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  object.reserve(matches.size());
  image.reserve(matches.size());
  for (size_t i = 0; i < matches.size(); ++i) {
    object.emplace_back(points_3d[i].x(), points_3d[i].y(), points_3d[i].z());
    image.emplace_back(normalized[i].x(), normalized[i].y());
  }
  const cv::Mat K = cv::Mat::eye(3, 3, CV_64F);
  cv::Mat rvec, tvec;
  std::vector<int> ransac_inliers;
  bool ok = false;
  try {
    // AP3P hypotheses from 4-point samples (a clean sample is far likelier than EPnP's 5 at the
    // 30-50 % inlier rates of a seabed revisit), EPnP on all inliers of the best one; OpenCV's
    // RANSAC uses a fixed seed, so the result is deterministic.
    // The cap: had min_inliers of the matches been inliers, a clean 4-point sample would have
    // come with probability pnp_confidence (x3, see ransacIterationsToReject). Once an acceptable
    // consensus is found, OpenCV's adaptive stop ends the search within that many anyway; the cap
    // only shortens the search for consensus sets that are not there.
    const int iterations =
        std::min(options_.pnp_iterations,
                 ransacIterationsToReject(matches.size(), min_inliers, options_.pnp_confidence, /*sample_size=*/4));
    ok = cv::solvePnPRansac(object, image, K, cv::noArray(), rvec, tvec, false, iterations,
                            static_cast<float>(threshold), options_.pnp_confidence, ransac_inliers, cv::SOLVEPNP_AP3P);
  } catch (const cv::Exception&) {
    ok = false;  // degenerate configurations (all points collinear, ...) are a rejection, not a crash
  }
  *num_inliers = static_cast<int>(ransac_inliers.size());
  if (!ok || *num_inliers < min_inliers) return std::nullopt;
  // Refine on the inliers (Levenberg-Marquardt on the reprojection error); the caller recounts.
  std::vector<cv::Point3d> object_in;
  std::vector<cv::Point2d> image_in;
  for (int i : ransac_inliers) {
    object_in.push_back(object[static_cast<size_t>(i)]);
    image_in.push_back(image[static_cast<size_t>(i)]);
  }
  return refinedPose(object_in, image_in, rvec, tvec);
}

std::optional<Eigen::Isometry3d> LoopVerifier::refinedPose(const std::vector<cv::Point3d>& object,
                                                           const std::vector<cv::Point2d>& image, cv::Mat rvec,
                                                           cv::Mat tvec) const {
  try {
    cv::solvePnPRefineLM(object, image, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec,
                         cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 1e-12));
  } catch (const cv::Exception&) {
    return std::nullopt;
  }
  cv::Mat R_cv;
  cv::Rodrigues(rvec, R_cv);
  Eigen::Matrix3d R_c_odom;
  Eigen::Vector3d t_c_odom;
  cv::cv2eigen(R_cv, R_c_odom);
  cv::cv2eigen(tvec, t_c_odom);
  if (!R_c_odom.allFinite() || !t_c_odom.allFinite()) return std::nullopt;
  Eigen::Isometry3d T_c_odom = Eigen::Isometry3d::Identity();
  T_c_odom.linear() = R_c_odom;
  T_c_odom.translation() = t_c_odom;
  return T_c_odom;
}

std::vector<std::pair<uint32_t, uint32_t>> LoopVerifier::inliersUnder(const DescribedPoints& points,
                                                                      const std::vector<PointMatch>& matches,
                                                                      const VisualSubmap& sub,
                                                                      const Eigen::Isometry3d& T_c_odom) const {
  const double threshold = pnpThreshold();
  std::vector<std::pair<uint32_t, uint32_t>> inliers;
  for (const PointMatch& m : matches) {
    const Eigen::Vector3d p_c = T_c_odom * points.p_odom[m.point];
    if (!(p_c.z() > 0.0)) continue;  // a point behind the camera is never an inlier
    const Eigen::Vector2d e = p_c.head<2>() / p_c.z() - sub.normalized[m.keypoint];
    if (e.norm() <= threshold) inliers.emplace_back(m.point, m.keypoint);
  }
  return inliers;
}

}  // namespace vims
