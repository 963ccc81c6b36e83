/// 3D-2D descriptor matching (matchPointsToKeypoints) against a brute-force reference written
/// from its definition (loop_detector.h): the matcher groups the candidate's keypoints by octave
/// and compares a point only with the groups its level window admits, with early exits in the
/// ratio test; none of that may change a match. And the guided matching by projection.

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

#include "vims_common/camera_model.h"
#include "vims_pose_graph/loop_detector.h"

namespace vims {
namespace {

/// matchPointsToKeypoints() by its definition: every point against every keypoint.
std::vector<PointMatch> bruteForceMatches(const DescribedPoints& points, const VisualSubmap& candidate, double ratio,
                                          int max_distance, double duplicate_radius_px, const LevelWindow& levels) {
  std::vector<PointMatch> matches;
  const size_t n = candidate.keypoints.size();
  for (uint32_t p = 0; p < points.numPoints(); ++p) {
    std::vector<int> distance(n, 257);
    for (size_t k = 0; k < n; ++k)
      for (size_t d = 0; d < points.descriptors.size(); ++d)
        if (points.point_of_descriptor[d] == p &&
            levels.admits(points.level_of_descriptor[d], candidate.keypoints[k].octave))
          distance[k] = std::min(distance[k], hammingDistance(points.descriptors[d], candidate.descriptors[k]));
    if (n == 0) continue;
    const size_t best = static_cast<size_t>(std::min_element(distance.begin(), distance.end()) - distance.begin());
    if (distance[best] > max_distance) continue;
    int second = 257;
    for (size_t k = 0; k < n; ++k) {
      const cv::Point2f d = candidate.keypoints[k].pt - candidate.keypoints[best].pt;
      if (k != best &&
          static_cast<double>(d.x) * d.x + static_cast<double>(d.y) * d.y > duplicate_radius_px * duplicate_radius_px)
        second = std::min(second, distance[k]);
    }
    if (ratio < 1.0 && !(distance[best] < ratio * second)) continue;
    matches.push_back(PointMatch{p, static_cast<uint32_t>(best), distance[best]});
  }
  std::vector<PointMatch> unique;
  for (const PointMatch& m : matches) {
    bool keep = true;
    for (const PointMatch& o : matches)
      if (o.keypoint == m.keypoint && (o.distance < m.distance || (o.distance == m.distance && o.point < m.point)))
        keep = false;
    if (keep) unique.push_back(m);
  }
  return unique;
}

BinaryDescriptor randomDescriptor(std::mt19937& rng) {
  BinaryDescriptor d;
  for (uint64_t& w : d.words) w = (static_cast<uint64_t>(rng()) << 32) ^ rng();
  return d;
}

/// `d` with `bits` distinct random bits flipped.
BinaryDescriptor flipped(BinaryDescriptor d, int bits, std::mt19937& rng) {
  std::vector<int> order(256);
  for (int i = 0; i < 256; ++i) order[static_cast<size_t>(i)] = i;
  std::shuffle(order.begin(), order.end(), rng);
  for (int i = 0; i < bits; ++i) {
    const int b = order[static_cast<size_t>(i)];
    d.words[static_cast<size_t>(b >> 6)] ^= uint64_t{1} << (b & 63);
  }
  return d;
}

/// Random points (1-4 descriptors each on distinct levels 0-8, one point without any) and a
/// candidate whose keypoints are random, noisy copies of the points' descriptors (Hamming 0-90),
/// exact copies at another place (ties), and copies 1-3 px away on another octave (one corner
/// on several levels); octaves 0-7 plus a few outside the grouped range (-1, 20).
void makeScene(std::mt19937& rng, DescribedPoints* points, VisualSubmap* candidate) {
  std::uniform_int_distribution<int> level(0, 8);
  std::uniform_real_distribution<float> u(0.0f, 640.0f);
  const int num_points = 120;
  std::vector<BinaryDescriptor> base;
  for (int p = 0; p < num_points; ++p) {
    points->p_odom.emplace_back(0, 0, 1);
    points->pixel.emplace_back(0, 0);
    points->feature_id.push_back(static_cast<uint64_t>(p));
    base.push_back(randomDescriptor(rng));
    if (p == 7) continue;  // a point without descriptors
    std::vector<int> levels;
    const int count = 1 + static_cast<int>(rng() % 4);
    while (static_cast<int>(levels.size()) < count) {
      const int l = level(rng);
      if (std::find(levels.begin(), levels.end(), l) == levels.end()) levels.push_back(l);
    }
    for (int l : levels) {
      points->descriptors.push_back(flipped(base.back(), static_cast<int>(rng() % 20), rng));
      points->point_of_descriptor.push_back(static_cast<uint32_t>(p));
      points->level_of_descriptor.push_back(l);
    }
  }
  auto add = [&](const BinaryDescriptor& d, cv::Point2f pt, int octave) {
    candidate->keypoints.emplace_back(pt, 31.0f, -1.0f, 0.0f, octave);
    candidate->descriptors.push_back(d);
    candidate->normalized.emplace_back(0.0, 0.0);
  };
  for (int i = 0; i < 700; ++i) {
    const int kind = static_cast<int>(rng() % 10);
    const int octave = kind == 0 ? (rng() % 2 ? -1 : 20) : static_cast<int>(rng() % 8);
    const cv::Point2f pt(u(rng), u(rng));
    if (kind <= 2 || candidate->keypoints.empty()) {
      add(randomDescriptor(rng), pt, octave);
    } else if (kind <= 6) {
      add(flipped(base[rng() % base.size()], static_cast<int>(rng() % 91), rng), pt, octave);
    } else if (kind <= 8) {
      const size_t k = rng() % candidate->keypoints.size();
      add(candidate->descriptors[k], pt, octave);  // the same descriptor at another place
    } else {
      const size_t k = rng() % candidate->keypoints.size();
      const cv::Point2f near = candidate->keypoints[k].pt + cv::Point2f(1.0f + static_cast<float>(rng() % 3), 0.0f);
      add(flipped(candidate->descriptors[k], static_cast<int>(rng() % 4), rng), near, octave);
    }
  }
}

TEST(PointMatching, OctaveGroupedMatchingEqualsBruteForce) {
  std::mt19937 rng(20261122);
  const std::vector<LevelWindow> windows = {LevelWindow::around(-1), LevelWindow::around(0), LevelWindow::around(2),
                                            LevelWindow{1.7, 1.0},   LevelWindow{-2.3, 0.5}, LevelWindow{0.4, 0.0}};
  struct Thresholds {
    double ratio;
    int max_distance;
  };
  const std::vector<Thresholds> thresholds = {{0.9, 80}, {0.8, 80}, {1.0, 80}, {0.9, 256}, {0.3, 256}, {0.9, 20}};
  size_t total = 0;
  for (int scene = 0; scene < 3; ++scene) {
    DescribedPoints points;
    VisualSubmap candidate;
    makeScene(rng, &points, &candidate);
    for (const LevelWindow& levels : windows)
      for (const Thresholds& t : thresholds) {
        const std::vector<PointMatch> expected =
            bruteForceMatches(points, candidate, t.ratio, t.max_distance, 4.0, levels);
        const std::vector<PointMatch> got =
            matchPointsToKeypoints(points, candidate, t.ratio, t.max_distance, 4.0, levels);
        ASSERT_EQ(got.size(), expected.size()) << "scene " << scene << " shift " << levels.shift << " tolerance "
                                               << levels.tolerance << " ratio " << t.ratio << " max " << t.max_distance;
        for (size_t i = 0; i < got.size(); ++i) {
          EXPECT_EQ(got[i].point, expected[i].point) << i;
          EXPECT_EQ(got[i].keypoint, expected[i].keypoint) << i;
          EXPECT_EQ(got[i].distance, expected[i].distance) << i;
        }
        total += expected.size();
      }
  }
  // The scenes exercise matching: many matches over all settings, not an empty comparison.
  EXPECT_GT(total, 1000u);
}

TEST(PointMatching, TiesGoToTheLowerKeypointIndexAcrossOctaves) {
  // One point, descriptors on levels 1 and 5; the same descriptor as keypoint 2 (octave 5) and
  // keypoint 0 (octave 1), far apart: with ratio 1 the lower index wins (as in a scan in
  // candidate order, whatever order the octave groups are visited in); a window admitting only
  // octave 5 picks keypoint 2.
  DescribedPoints p;
  p.p_odom.emplace_back(0, 0, 1);
  p.pixel.emplace_back(0, 0);
  p.feature_id.push_back(0);
  BinaryDescriptor a;
  for (int i = 0; i < 40; ++i) a.setBit(i * 3);
  for (int level : {5, 1}) {
    p.descriptors.push_back(a);
    p.point_of_descriptor.push_back(0);
    p.level_of_descriptor.push_back(level);
  }
  VisualSubmap s;
  auto add = [&](const BinaryDescriptor& d, float x, int octave) {
    s.keypoints.emplace_back(cv::Point2f(x, 10.0f), 31.0f, -1.0f, 0.0f, octave);
    s.descriptors.push_back(d);
    s.normalized.emplace_back(0.0, 0.0);
  };
  BinaryDescriptor far_away;
  for (int i = 0; i < 256; i += 2) far_away.setBit(i);
  add(a, 10.0f, 1);
  add(far_away, 50.0f, 3);
  add(a, 300.0f, 5);
  const std::vector<PointMatch> any = matchPointsToKeypoints(p, s, 1.0, 80, 4.0, LevelWindow::around(0));
  ASSERT_EQ(any.size(), 1u);
  EXPECT_EQ(any[0].keypoint, 0u);
  EXPECT_EQ(any[0].distance, 0);
  // Both exact copies compete: the ratio test rejects the point.
  EXPECT_TRUE(matchPointsToKeypoints(p, s, 0.9, 80, 4.0, LevelWindow::around(0)).empty());
  const std::vector<PointMatch> only5 = matchPointsToKeypoints(p, s, 0.9, 80, 4.0, LevelWindow{4.0, 0.0});
  ASSERT_EQ(only5.size(), 1u);  // level 1 + 4 = octave 5 only: keypoint 2, no competitor
  EXPECT_EQ(only5[0].keypoint, 2u);
}

// Guided matching (matchPointsByProjection): a point is matched with the closest keypoint near
// where the pose projects it. Points over a plane 2 m below a pinhole camera, each with a
// keypoint at its projection (a noisy copy of its descriptor) among random keypoints.
TEST(PointMatching, ProjectionMatchesOnlyNearThePredictedPixel) {
  CameraCalibration calibration;
  calibration.width = 640;
  calibration.height = 480;
  calibration.fx = calibration.fy = 400.0;
  calibration.cx = 320.0;
  calibration.cy = 240.0;
  const CameraModel camera(calibration);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.4, 1.4);
  DescribedPoints points;
  VisualSubmap candidate;
  auto addKeypoint = [&](const BinaryDescriptor& d, const Eigen::Vector2d& pixel) {
    candidate.keypoints.emplace_back(cv::Point2f(static_cast<float>(pixel.x()), static_cast<float>(pixel.y())), 31.0f,
                                     -1.0f, 0.0f, 0);
    candidate.descriptors.push_back(d);
    candidate.normalized.emplace_back(0.0, 0.0);
  };
  const int num_points = 60;
  for (int p = 0; p < num_points; ++p) {
    const Eigen::Vector3d p_c(u(rng), 0.7 * u(rng), 2.0);
    points.p_odom.push_back(p_c);
    points.pixel.emplace_back(0.0, 0.0);
    points.feature_id.push_back(static_cast<uint64_t>(p));
    const BinaryDescriptor d = randomDescriptor(rng);
    points.descriptors.push_back(d);
    points.point_of_descriptor.push_back(static_cast<uint32_t>(p));
    points.level_of_descriptor.push_back(0);
    addKeypoint(flipped(d, 20, rng), *camera.project(p_c));
  }
  for (int k = 0; k < 300; ++k)
    addKeypoint(randomDescriptor(rng), Eigen::Vector2d(640.0 * (u(rng) + 1.4) / 2.8, 480.0 * (u(rng) + 1.4) / 2.8));
  // A point behind the camera has no projection.
  points.p_odom.emplace_back(0.0, 0.0, -2.0);
  points.pixel.emplace_back(0.0, 0.0);
  points.feature_id.push_back(num_points);
  points.descriptors.push_back(candidate.descriptors[0]);
  points.point_of_descriptor.push_back(num_points);
  points.level_of_descriptor.push_back(0);

  const auto correct = [&](const std::vector<PointMatch>& matches) {
    int n = 0;
    for (const PointMatch& m : matches) n += m.point == m.keypoint ? 1 : 0;
    return n;
  };
  const LevelWindow any = LevelWindow::around(-1);
  const std::vector<PointMatch> exact =
      matchPointsByProjection(points, candidate, camera, Eigen::Isometry3d::Identity(), 10.0, 0.9, 80, 4.0, any);
  EXPECT_EQ(correct(exact), num_points);
  EXPECT_EQ(exact.size(), static_cast<size_t>(num_points));
  // A pose 6 cm off (12 px at 2 m): within a 20 px radius, not within 10 px.
  Eigen::Isometry3d off = Eigen::Isometry3d::Identity();
  off.translation().x() = 0.06;
  EXPECT_EQ(correct(matchPointsByProjection(points, candidate, camera, off, 20.0, 0.9, 80, 4.0, any)), num_points);
  EXPECT_EQ(correct(matchPointsByProjection(points, candidate, camera, off, 10.0, 0.9, 80, 4.0, any)), 0);
  // A second keypoint as close in descriptor 6 px from point 0's: ambiguous, unless ratio 1.
  addKeypoint(candidate.descriptors[0], *camera.project(points.p_odom[0]) + Eigen::Vector2d(6.0, 0.0));
  const auto matched0 = [](const std::vector<PointMatch>& matches) {
    return std::any_of(matches.begin(), matches.end(), [](const PointMatch& m) { return m.point == 0; });
  };
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  EXPECT_FALSE(matched0(matchPointsByProjection(points, candidate, camera, I, 10.0, 0.9, 80, 4.0, any)));
  EXPECT_TRUE(matched0(matchPointsByProjection(points, candidate, camera, I, 10.0, 1.0, 80, 4.0, any)));
}

}  // namespace
}  // namespace vims
