// The seabed level under a sonar hit from the hits around it (seabed_level.h): roughness averages
// out, the gradient carries hits to the centre, a rock is left out, far hits are ignored.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vims_estimator/seabed_level.h"

namespace vims {
namespace {

// A 4 deg slope along x: h(x, y) = 0.07 x - 20.
double smoothSeabed(const Eigen::Vector2d& xy) { return 0.07 * xy.x() - 20.0; }

std::vector<Eigen::Vector3d> roughHits(double roughness_std, unsigned seed, int n) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> rough(0.0, roughness_std);
  std::vector<Eigen::Vector3d> hits;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d xy(-2.0 + 4.0 * i / (n - 1), 0.05 * std::sin(i));  // a transit along x
    hits.emplace_back(xy.x(), xy.y(), smoothSeabed(xy) + rough(rng));
  }
  return hits;
}

TEST(SeabedLevel, RadiusFromFlatnessAndGradientRandomWalk) {
  // q^2 R^3 / 3 = sigma_f^2: 0.05 m flatness, 0.02 / sqrt(m) gives R = cbrt(18.75) = 2.66 m.
  EXPECT_NEAR(seabedLevelRadius(0.05, 0.02, 10.0), 2.657, 1e-3);
  EXPECT_EQ(seabedLevelRadius(0.0, 0.02, 10.0), 0.0);   // a perfect plane: the hit is exact
  EXPECT_EQ(seabedLevelRadius(0.05, 0.0, 10.0), 10.0);  // a fixed gradient: as far as the plane holds
  EXPECT_EQ(seabedLevelRadius(0.5, 0.001, 10.0), 10.0);
}

TEST(SeabedLevel, AveragesRoughnessAlongTheGradient) {
  // 0.1 m of roughness under each of 41 hits over 4 m: the level at the middle hit is the smooth
  // seabed to ~0.1 / sqrt(35) = 0.017 m (the kernel weights leave ~35 effective hits), the
  // middle hit alone is off by its roughness.
  double level_sq = 0.0, hit_sq = 0.0;
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    const auto hits = roughHits(0.1, 7 + t, 41);
    const Eigen::Vector3d& centre = hits[20];
    const auto level = seabedLevelAt(centre, Eigen::Vector2d(0.07, 0.0), hits, 2.5, 1.0);
    ASSERT_TRUE(level.has_value());
    EXPECT_EQ(level->hits, 41);
    const double truth = smoothSeabed(centre.head<2>());
    level_sq += std::pow(level->height - truth, 2);
    hit_sq += std::pow(centre.z() - truth, 2);
  }
  const double level_rms = std::sqrt(level_sq / trials), hit_rms = std::sqrt(hit_sq / trials);
  RecordProperty("level_rms_m", std::to_string(level_rms));
  EXPECT_LT(level_rms, 0.035);  // measured 0.0173
  EXPECT_GT(hit_rms, 0.07);    // the roughness itself, 0.1
  // Carried along a wrong (level) gradient the 4 deg slope would bias a one-sided average: the
  // gradient is what makes the neighbours' hits comparable.
  const auto hits = roughHits(0.0, 1, 41);
  const auto one_sided = std::vector<Eigen::Vector3d>(hits.begin(), hits.begin() + 21);
  const auto sloped = seabedLevelAt(hits[20], Eigen::Vector2d(0.07, 0.0), one_sided, 2.5, 1.0);
  const auto level = seabedLevelAt(hits[20], Eigen::Vector2d::Zero(), one_sided, 2.5, 1.0);
  EXPECT_NEAR(sloped->height, hits[20].z(), 1e-9);
  EXPECT_GT(std::abs(level->height - hits[20].z()), 0.03);
}

TEST(SeabedLevel, LeavesOutARockAndFarHits) {
  auto hits = roughHits(0.0, 1, 21);
  hits[10].z() += 0.8;                                     // a rock under the centre's own ping
  hits.emplace_back(50.0, 0.0, smoothSeabed({50.0, 0.0}) + 3.0);  // far away: ignored
  const auto level = seabedLevelAt(hits[10], Eigen::Vector2d(0.07, 0.0), hits, 2.5, 0.14);
  ASSERT_TRUE(level.has_value());
  EXPECT_EQ(level->hits, 20);
  EXPECT_NEAR(level->height, smoothSeabed(hits[10].head<2>()), 1e-9);  // the seabed, not the rock top
  // No hit within the radius (a non-finite one does not count): no level.
  const std::vector<Eigen::Vector3d> none = {Eigen::Vector3d(9.0, 0.0, -20.0),
                                             Eigen::Vector3d(0.0, std::nan(""), -20.0)};
  EXPECT_FALSE(seabedLevelAt(Eigen::Vector3d(0.0, 0.0, -20.0), Eigen::Vector2d::Zero(), none, 2.5, 0.14).has_value());
}

TEST(SeabedLevel, HistoryKeepsTheNewestHitsWithinReach) {
  SeabedHitHistory history(2.0, 3);
  for (int i = 0; i < 5; ++i) history.add(Eigen::Vector3d(i, 0.0, -20.0));
  history.add(Eigen::Vector3d(std::nan(""), 0.0, 0.0));  // dropped
  ASSERT_EQ(history.hits().size(), 3u);                  // the newest three: x = 2, 3, 4
  EXPECT_EQ(history.hits().front().x(), 2.0);
  history.prune(Eigen::Vector2d(7.5, 0.0));  // reach 4 m: x = 4 stays
  ASSERT_EQ(history.hits().size(), 1u);
  EXPECT_EQ(history.hits().front().x(), 4.0);
}

}  // namespace
}  // namespace vims
