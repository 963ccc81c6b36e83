/// The keyframe describer's shortcuts against what they replace: Shi-Tomasi candidates computed
/// once and selected twice against cv::goodFeaturesToTrack, and the one-pass description of a
/// keyframe (one pyramid, one cv::ORB::compute call) against separate describe calls, on
/// keyframes rendered by the simulator's seabed renderer. docs/pose_graph.md, "Corner replication".

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "loop_test_world.h"
#include "vims_pose_graph/keyframe_description.h"
#include "vims_pose_graph/loop_closing_options.h"

namespace vims {
namespace {

using test::bodyPose;
using test::yawTransform;

constexpr uint64_t kWorldSeed = 4242;  // not the vocabulary's training world (9001)

void expectSameCorners(const std::vector<cv::Point2f>& expected, const std::vector<cv::Point2f>& actual,
                       const std::string& what) {
  ASSERT_EQ(expected.size(), actual.size()) << what;
  for (size_t i = 0; i < expected.size(); ++i) {
    ASSERT_EQ(expected[i].x, actual[i].x) << what << ", corner " << i;
    ASSERT_EQ(expected[i].y, actual[i].y) << what << ", corner " << i;
  }
}

/// Every selection the describer makes (and some it does not) on one image: the same corners, in
/// the same order, as cv::goodFeaturesToTrack with the tracker's settings; from fresh candidates
/// and from candidates that earlier selections have partly sorted.
void expectSelectionsEqualGoodFeaturesToTrack(const cv::Mat& image, const std::string& what) {
  ShiTomasiCandidates reused(image, 0.001, 3);
  const std::vector<std::pair<int, double>> selections = {{800, 4.0}, {400, 4.0}, {150, 30.0}, {0, 4.0},
                                                          {60, 10.6}, {300, 0.5}, {1, 4.0}};
  for (const auto& [max_corners, min_distance] : selections) {
    const std::string selection =
        what + ", max " + std::to_string(max_corners) + ", distance " + std::to_string(min_distance);
    std::vector<cv::Point2f> reference;
    cv::goodFeaturesToTrack(image, reference, max_corners, 0.001, min_distance, cv::noArray(), 3, false);
    ShiTomasiCandidates fresh(image, 0.001, 3);
    expectSameCorners(reference, fresh.select(max_corners, min_distance), selection + ", fresh");
    expectSameCorners(reference, reused.select(max_corners, min_distance), selection + ", reused");
  }
}

TEST(ShiTomasiCandidates, SelectionEqualsGoodFeaturesToTrack) {
  test::TestWorld world(kWorldSeed);
  FeatureExtractionOptions fo;
  for (int view = 0; view < 3; ++view) {
    const cv::Mat image = world.render(bodyPose(0.7 * view, -0.4 * view, 2.2 + 0.8 * view, 30.0 * view), 11 + view);
    const std::vector<cv::Mat> pyramid = buildOrbPyramid(image, fo.orb_scale_factor, fo.orb_levels);
    ASSERT_EQ(pyramid.size(), static_cast<size_t>(fo.orb_levels));
    for (int level = 0; level <= 3; ++level) {
      SCOPED_TRACE("view " + std::to_string(view) + ", level " + std::to_string(level));
      expectSelectionsEqualGoodFeaturesToTrack(pyramid[static_cast<size_t>(level)], "rendered");
    }
  }
  // Exactly equal responses everywhere (a tiled pattern): OpenCV's tie order (later pixel first)
  // decides which of the equal corners are taken.
  cv::Mat tiles(120, 160, CV_8UC1, cv::Scalar(40));
  for (int y = 0; y < tiles.rows; y += 8)
    for (int x = 0; x < tiles.cols; x += 8) cv::rectangle(tiles, cv::Rect(x + 2, y + 2, 3, 3), cv::Scalar(200), -1);
  {
    SCOPED_TRACE("tiles");
    expectSelectionsEqualGoodFeaturesToTrack(tiles, "tiles");
  }
  // No corner at all.
  ShiTomasiCandidates flat(cv::Mat(60, 80, CV_8UC1, cv::Scalar(90)), 0.001, 3);
  EXPECT_EQ(flat.size(), 0u);
  EXPECT_TRUE(flat.select(100, 4.0).empty());
}

// KeyframeImage::cornersOnLevel computes each level's response once and serves both the dense
// corners (800 / 1.2^(2l)) and the seabed corners (400 / 1.2^(2(l-1))) from it.
TEST(ShiTomasiCandidates, KeyframeImageCornersEqualGoodFeaturesToTrackPerLevel) {
  test::TestWorld world(kWorldSeed);
  const cv::Mat image = world.render(bodyPose(1.0, 0.5, 2.6, 15.0), 3);
  KeyframeImage prepared(image, 1.2, 8);
  for (int level = 0; level <= 3; ++level) {
    for (const int n : {800, 400, 123}) {
      std::vector<cv::Point2f> reference;
      cv::goodFeaturesToTrack(prepared.pyramid()[static_cast<size_t>(level)], reference, n, 0.001, 4.0, cv::noArray(),
                              3, false);
      const float scale = static_cast<float>(std::pow(1.2, level));
      for (cv::Point2f& c : reference) c *= scale;
      expectSameCorners(reference, prepared.cornersOnLevel(level, n, 4.0),
                        "level " + std::to_string(level) + ", max " + std::to_string(n));
    }
  }
  EXPECT_TRUE(prepared.cornersOnLevel(8, 100, 4.0).empty());
  EXPECT_TRUE(prepared.cornersOnLevel(1, 0, 4.0).empty());
}

void expectSameDescriptors(const DescribedPoints& expected, const DescribedPoints& actual, const std::string& what) {
  ASSERT_EQ(expected.feature_id, actual.feature_id) << what;
  ASSERT_EQ(expected.numPoints(), actual.numPoints()) << what;
  for (size_t i = 0; i < expected.numPoints(); ++i) {
    ASSERT_EQ(expected.pixel[i], actual.pixel[i]) << what;
    ASSERT_EQ(expected.p_odom[i], actual.p_odom[i]) << what;
  }
  ASSERT_EQ(expected.point_of_descriptor, actual.point_of_descriptor) << what;
  ASSERT_EQ(expected.level_of_descriptor, actual.level_of_descriptor) << what;
  ASSERT_EQ(expected.descriptors.size(), actual.descriptors.size()) << what;
  for (size_t d = 0; d < expected.descriptors.size(); ++d)
    ASSERT_EQ(expected.descriptors[d], actual.descriptors[d]) << what << ", descriptor " << d;
}

/// `described` restricted to the descriptors of pyramid level `level` (all points kept).
DescribedPoints onLevel(const DescribedPoints& described, int level) {
  DescribedPoints out = described;
  out.descriptors.clear();
  out.point_of_descriptor.clear();
  out.level_of_descriptor.clear();
  for (size_t d = 0; d < described.descriptors.size(); ++d) {
    if (described.level_of_descriptor[d] != level) continue;
    out.descriptors.push_back(described.descriptors[d]);
    out.point_of_descriptor.push_back(described.point_of_descriptor[d]);
    out.level_of_descriptor.push_back(level);
  }
  return out;
}

std::vector<KeyframeLandmark> landmarksOf(const DescribedPoints& points) {
  std::vector<KeyframeLandmark> out(points.numPoints());
  for (size_t i = 0; i < out.size(); ++i) {
    out[i].id = points.feature_id[i];
    out[i].p_odom = points.p_odom[i];
    out[i].pixel = points.pixel[i];
  }
  return out;
}

// The one-pass description (one pyramid, each level's corner response once, ONE cv::ORB::compute
// call for tracked, dense and seabed keypoints) gives bit-identical results to describing each
// part separately: every describePoints call below runs its own cv::ORB::compute on its own
// keypoints only, as the describer did before.
TEST(KeyframeDescriber, OnePassEqualsSeparateCalls) {
  test::TestWorld world(kWorldSeed);
  const LoopDetectorOptions o;
  ASSERT_TRUE(o.submap_dense_corners_per_level);
  ASSERT_GT(o.query_seabed_corners, 0);
  KeyframeDescriber describer(FeatureExtractionOptions(), o.harris_threshold, world.camera());
  describer.setDenseCorners(o.submap_dense_corners, o.submap_corner_min_distance_px, o.submap_corner_max_level);
  describer.setDenseCornersPerLevel(true);
  describer.setSeabedCorners(o.query_seabed_corners, o.submap_corner_min_distance_px, o.submap_corner_max_level);
  const auto vocabulary = test::vocabulary("orb_k8l4.vocab");

  const Eigen::Isometry3d T_w_b = bodyPose(3.0, -1.0, 3.2, 40.0, 2.0, -3.0);
  const Eigen::Isometry3d T_odom_w = yawTransform(25.0, Eigen::Vector3d(-2.0, 5.0, 1.0));
  const KeyframeData kf = world.trackerKeyframe(5.0, 0, T_w_b, T_odom_w * T_w_b, 7);
  const Eigen::Isometry3d T_odom_c = kf.T_odom_b * world.camera().T_b_c;
  const KeyframeDescription one_pass =
      describer.describeKeyframeAndSeabed(kf.image, kf.features, T_odom_c, vocabulary.get());

  // The image's own ORB keypoints and BoW vector come first.
  const VisualSubmap image_only = describer.describeImage(kf.image, vocabulary.get());
  ASSERT_GT(image_only.keypoints.size(), 100u);
  ASSERT_FALSE(image_only.bow.empty());
  ASSERT_EQ(image_only.bow.size(), one_pass.submap.bow.size());
  for (size_t i = 0; i < image_only.bow.size(); ++i) {
    EXPECT_EQ(image_only.bow.entries[i].word, one_pass.submap.bow.entries[i].word);
    EXPECT_EQ(image_only.bow.entries[i].weight, one_pass.submap.bow.entries[i].weight);
  }
  // Tracked points on all levels, then the dense corners of each level 0..3 on their level.
  const DescribedPoints tracked = describer.describePoints(kf.image, kf.features);
  ASSERT_GT(tracked.descriptors.size(), tracked.numPoints());  // several levels per point
  expectSameDescriptors(tracked, one_pass.points, "tracked points");
  std::vector<BinaryDescriptor> expected_descriptors = image_only.descriptors;
  std::vector<int> expected_octaves;
  for (const cv::KeyPoint& kp : image_only.keypoints) expected_octaves.push_back(kp.octave);
  std::vector<cv::Point2f> expected_pixels;
  for (const cv::KeyPoint& kp : image_only.keypoints) expected_pixels.push_back(kp.pt);
  auto append = [&](const DescribedPoints& part) {
    for (size_t d = 0; d < part.descriptors.size(); ++d) {
      expected_descriptors.push_back(part.descriptors[d]);
      expected_octaves.push_back(part.level_of_descriptor[d]);
      const Eigen::Vector2d& px = part.pixel[part.point_of_descriptor[d]];
      expected_pixels.emplace_back(static_cast<float>(px.x()), static_cast<float>(px.y()));
    }
  };
  append(tracked);
  KeyframeImage prepared(kf.image, 1.2, 8);
  size_t dense_descriptors = 0;
  for (int level = 0; level <= o.submap_corner_max_level; ++level) {
    const int n = static_cast<int>(std::lround(o.submap_dense_corners / std::pow(1.2, 2.0 * level)));
    std::vector<KeyframeLandmark> corners;
    for (const cv::Point2f& c : prepared.cornersOnLevel(level, n, o.submap_corner_min_distance_px)) {
      KeyframeLandmark l;
      l.pixel = Eigen::Vector2d(c.x, c.y);
      corners.push_back(l);
    }
    const DescribedPoints on_level = onLevel(describer.describePoints(kf.image, corners, level), level);
    ASSERT_GT(on_level.descriptors.size(), 50u) << "level " << level;
    dense_descriptors += on_level.descriptors.size();
    append(on_level);
  }
  EXPECT_GT(dense_descriptors, 1000u);
  ASSERT_EQ(expected_descriptors.size(), one_pass.submap.descriptors.size());
  ASSERT_EQ(one_pass.submap.keypoints.size(), one_pass.submap.descriptors.size());
  ASSERT_EQ(one_pass.submap.normalized.size(), one_pass.submap.descriptors.size());
  for (size_t i = 0; i < expected_descriptors.size(); ++i) {
    ASSERT_EQ(expected_descriptors[i], one_pass.submap.descriptors[i]) << "submap descriptor " << i;
    ASSERT_EQ(expected_octaves[i], one_pass.submap.keypoints[i].octave) << "submap keypoint " << i;
    ASSERT_EQ(expected_pixels[i], one_pass.submap.keypoints[i].pt) << "submap keypoint " << i;
  }
  // The same submap through the API without seabed corners.
  DescribedPoints points;
  const VisualSubmap submap = describer.describeKeyframe(kf.image, kf.features, vocabulary.get(), &points);
  ASSERT_EQ(submap.descriptors, one_pass.submap.descriptors);
  expectSameDescriptors(tracked, points, "describeKeyframe's points");

  // Seabed corners: as the separate call, and each descriptor as describing those points alone.
  const DescribedPoints seabed = describer.describeSeabedCorners(
      kf.image, tracked, T_odom_c, o.query_seabed_corners, o.submap_corner_min_distance_px, o.submap_corner_max_level);
  ASSERT_GT(seabed.descriptors.size(), 200u);
  expectSameDescriptors(seabed, one_pass.seabed_points, "seabed corners");
  const DescribedPoints alone = describer.describePoints(kf.image, landmarksOf(seabed), o.submap_corner_max_level);
  ASSERT_EQ(alone.numPoints(), seabed.numPoints());
  for (size_t d = 0; d < seabed.descriptors.size(); ++d) {
    bool found = false;
    for (size_t a = 0; a < alone.descriptors.size() && !found; ++a) {
      if (alone.point_of_descriptor[a] != seabed.point_of_descriptor[d] ||
          alone.level_of_descriptor[a] != seabed.level_of_descriptor[d])
        continue;
      found = true;
      EXPECT_EQ(alone.descriptors[a], seabed.descriptors[d]) << "seabed descriptor " << d;
    }
    EXPECT_TRUE(found) << "seabed descriptor " << d << " not described alone";
  }

  // Dense corners detected on level 0 only and replicated on levels 0..3
  // (submap_dense_corners_per_level false): cv::goodFeaturesToTrack's corners, described as such.
  describer.setDenseCornersPerLevel(false);
  const VisualSubmap replicated = describer.describeKeyframe(kf.image, kf.features, vocabulary.get(), nullptr);
  std::vector<cv::Point2f> level0;
  cv::goodFeaturesToTrack(toMono8(kf.image), level0, o.submap_dense_corners, 0.001, o.submap_corner_min_distance_px,
                          cv::noArray(), 3, false);
  std::vector<KeyframeLandmark> level0_landmarks;
  for (const cv::Point2f& c : level0) {
    KeyframeLandmark l;
    l.pixel = Eigen::Vector2d(c.x, c.y);
    level0_landmarks.push_back(l);
  }
  const DescribedPoints level0_described =
      describer.describePoints(kf.image, level0_landmarks, o.submap_corner_max_level);
  ASSERT_GT(level0_described.descriptors.size(), 500u);
  std::vector<BinaryDescriptor> expected_replicated = image_only.descriptors;
  expected_replicated.insert(expected_replicated.end(), tracked.descriptors.begin(), tracked.descriptors.end());
  expected_replicated.insert(expected_replicated.end(), level0_described.descriptors.begin(),
                             level0_described.descriptors.end());
  ASSERT_EQ(expected_replicated.size(), replicated.descriptors.size());
  for (size_t i = 0; i < expected_replicated.size(); ++i)
    ASSERT_EQ(expected_replicated[i], replicated.descriptors[i]) << "replicated dense submap descriptor " << i;
}

}  // namespace
}  // namespace vims
