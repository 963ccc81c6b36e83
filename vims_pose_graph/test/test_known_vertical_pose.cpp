#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "vims_pose_graph/known_vertical_pose.h"

namespace vims {
namespace {

/// A downward camera 2-4 m above a rough seabed, tilted by a few degrees, at yaw `yaw`.
struct Scene {
  Eigen::Matrix3d A;  // attitude without the yaw (what the VIO gives)
  double yaw = 0.0;
  Eigen::Matrix3d R_points_cam;  // Rz(yaw) A
  Eigen::Vector3d centre;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> normalized;
};

Scene makeScene(std::mt19937& rng, int n, double noise = 0.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Scene s;
  const Eigen::Matrix3d down = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();  // z_cam = -z
  s.A = (Eigen::AngleAxisd(0.7 * u(rng), Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(0.08 * u(rng), Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(0.08 * u(rng), Eigen::Vector3d::UnitY()))
            .toRotationMatrix() *
        down;
  s.yaw = 3.0 * u(rng);
  s.R_points_cam = Eigen::AngleAxisd(s.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * s.A;
  s.centre = Eigen::Vector3d(5.0 * u(rng), 5.0 * u(rng), 3.0 + u(rng));
  while (static_cast<int>(s.points.size()) < n) {
    const Eigen::Vector2d x(0.5 * u(rng), 0.4 * u(rng));
    const Eigen::Vector3d ray = s.R_points_cam * x.homogeneous();
    if (!(ray.z() < -0.1)) continue;
    const double ground = 0.3 * u(rng);  // seabed height
    const double l = (ground - s.centre.z()) / ray.z();
    s.points.push_back(s.centre + l * ray);
    s.normalized.push_back(x + noise * Eigen::Vector2d(gauss(rng), gauss(rng)));
  }
  return s;
}

TEST(KnownVerticalPose, TwoPointsGiveTheExactPoseAmongAtMostTwo) {
  std::mt19937 rng(3);
  int found = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Scene s = makeScene(rng, 2);
    const auto hypotheses = solveKnownVerticalPose(s.points[0], s.points[1], s.normalized[0], s.normalized[1], s.A);
    ASSERT_LE(hypotheses.size(), 2u);
    bool exact = false;
    for (const VerticalPoseHypothesis& h : hypotheses) {
      // Every hypothesis reprojects both points exactly and has the known tilt.
      EXPECT_NEAR(
          (h.R_points_cam.transpose() * Eigen::Vector3d::UnitZ() - s.A.transpose() * Eigen::Vector3d::UnitZ()).norm(),
          0.0, 1e-9);
      for (int i = 0; i < 2; ++i) {
        const Eigen::Vector3d p = h.R_points_cam.transpose() * (s.points[i] - h.centre);
        ASSERT_GT(p.z(), 0.0);
        EXPECT_NEAR((p.head<2>() / p.z() - s.normalized[i]).norm(), 0.0, 1e-9);
      }
      exact =
          exact || ((h.centre - s.centre).norm() < 1e-7 && std::abs(std::remainder(h.yaw - s.yaw, 2 * M_PI)) < 1e-9);
    }
    found += exact ? 1 : 0;
  }
  EXPECT_EQ(found, 200);
}

TEST(KnownVerticalPose, DegenerateSamplesGiveNoHypothesis) {
  std::mt19937 rng(5);
  const Scene s = makeScene(rng, 2);
  // The same point twice, and the same bearing for two points.
  EXPECT_TRUE(solveKnownVerticalPose(s.points[0], s.points[0], s.normalized[0], s.normalized[0], s.A).empty());
  EXPECT_TRUE(solveKnownVerticalPose(s.points[0], s.points[1], s.normalized[0], s.normalized[0], s.A).empty());
}

TEST(KnownVerticalPose, ConsensusFindsTheInliersAndRulesOutOutliers) {
  std::mt19937 rng(11);
  const double threshold = 5.0 / 460.0;  // 5 px at a 460 px focal length
  // 30 inliers with 1 px noise among 120 matches (25 %), and 120 random matches.
  Scene s = makeScene(rng, 30, 1.0 / 460.0);
  const Scene other = makeScene(rng, 90);
  std::vector<Eigen::Vector3d> points = s.points;
  std::vector<Eigen::Vector2d> normalized = s.normalized;
  for (int i = 0; i < 90; ++i) {
    points.push_back(other.points[static_cast<size_t>(i)]);
    normalized.push_back(other.normalized[static_cast<size_t>((i * 37) % 90)]);  // shuffled: wrong matches
  }
  const int samples = ransacIterationsToReject(points.size(), 25, 0.99, 2);
  EXPECT_EQ(samples, 312);  // w = 25 / 120: ln(0.01) / ln(1 - w^2) = 103.8, x 3
  EXPECT_GT(ransacIterationsToReject(points.size(), 25, 0.99, 4), 10 * samples);
  const KnownVerticalConsensus found = knownVerticalConsensus(points, normalized, s.A, threshold, samples, 1000);
  EXPECT_GE(found.inliers, 27);  // nearly all 30 (the noisiest may fall out)
  EXPECT_LE(found.inliers, 40);  // chance agreement of a few wrong matches at most
  // Deterministic.
  EXPECT_EQ(knownVerticalConsensus(points, normalized, s.A, threshold, samples, 1000).inliers, found.inliers);

  // Wrong matches only: far below any acceptable consensus.
  std::vector<Eigen::Vector3d> wrong_points(other.points.begin(), other.points.end());
  std::vector<Eigen::Vector2d> wrong_normalized;
  for (int i = 0; i < 90; ++i) wrong_normalized.push_back(other.normalized[static_cast<size_t>((i * 37 + 11) % 90)]);
  const KnownVerticalConsensus none =
      knownVerticalConsensus(wrong_points, wrong_normalized, other.A, threshold, 500, 1000);
  EXPECT_LT(none.inliers, 10);
  // Early stop once enough inliers are found.
  const KnownVerticalConsensus early = knownVerticalConsensus(points, normalized, s.A, threshold, samples, 10);
  EXPECT_GE(early.inliers, 10);
  EXPECT_LE(early.samples, found.samples);
}

TEST(KnownVerticalPose, IterationsToReject) {
  EXPECT_EQ(ransacIterationsToReject(0, 25, 0.99, 2), 1);
  EXPECT_EQ(ransacIterationsToReject(20, 25, 0.99, 4), 1);  // fewer matches than needed inliers
  // w = 0.25: k = ln(0.01) / ln(1 - 0.0625) = 71.4 -> 3 x -> 215.
  EXPECT_EQ(ransacIterationsToReject(100, 25, 0.99, 2), 215);
}

}  // namespace
}  // namespace vims
