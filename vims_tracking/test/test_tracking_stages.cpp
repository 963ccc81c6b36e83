#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "vims_tracking/tracking_stages.h"

TEST(EpipolarRansac, RemovesInjectedWrongMatchesInA3dScene) {
  // Points at 1..6 m (a rough seabed with rocks) seen from two poses 0.15 m and 3 deg apart.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> lateral(-1.0, 1.0), depth(1.0, 6.0), shift(6.0, 40.0), sign(-1.0, 1.0);
  const Eigen::Matrix3d R_c2_c1 =
      Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
  const Eigen::Vector3d t_c2_c1(0.12, -0.05, 0.07);
  const double focal = 460.0;
  std::vector<Eigen::Vector2d> previous, current;
  std::vector<bool> injected;
  for (int i = 0; i < 150; ++i) {
    const double z = depth(rng);
    const Eigen::Vector3d p1(lateral(rng) * 0.7 * z, lateral(rng) * 0.5 * z, z);
    const Eigen::Vector3d p2 = R_c2_c1 * p1 + t_c2_c1;
    Eigen::Vector2d m2 = p2.hnormalized();
    const bool wrong = i % 8 == 3;  // ~12 % wrong tracks
    if (wrong) {
      // A wrong KLT match: displaced by 6..40 px in a random direction.
      const Eigen::Vector2d direction = Eigen::Vector2d(sign(rng), sign(rng)).normalized();
      m2 += direction * shift(rng) / focal;
    }
    previous.push_back(p1.hnormalized());
    current.push_back(m2);
    injected.push_back(wrong);
  }
  const vims::EpipolarCheck check = vims::epipolarRansac(previous, current, focal, 1.0, 0.99, 1000);
  ASSERT_TRUE(check.performed);
  int kept_wrong = 0, dropped_right = 0, wrong = 0;
  for (std::size_t i = 0; i < injected.size(); ++i) {
    wrong += injected[i];
    if (injected[i] && check.inlier[i]) ++kept_wrong;
    if (!injected[i] && !check.inlier[i]) ++dropped_right;
  }
  // A wrong match moved exactly along its epipolar line cannot be detected; allow one such case.
  EXPECT_LE(kept_wrong, 1) << "of " << wrong << " injected";
  EXPECT_LE(dropped_right, 3);
}

TEST(EpipolarRansac, KeepsEverythingWithTooFewCorrespondences) {
  // 12 exact matches of a shifted image: OpenCV would fall back to LMedS here and reject 5 of them.
  std::vector<Eigen::Vector2d> previous, current;
  for (int i = 0; i < 12; ++i) {
    previous.emplace_back(-0.5 + 0.09 * i, 0.3 - 0.05 * i * (i % 3));
    current.push_back(previous.back() + Eigen::Vector2d(0.005, 0.003));
  }
  const vims::EpipolarCheck check = vims::epipolarRansac(previous, current, 460.0, 1.0, 0.99, 100);
  EXPECT_FALSE(check.performed);
  EXPECT_EQ(check.inlier, std::vector<std::uint8_t>(12, 1));
}

TEST(EpipolarRansac, KeepsAllExactMatchesOfAPlanarScene) {
  // A flat seabed under pure translation is a degenerate configuration for the fundamental
  // matrix; exact matches must all still count as inliers.
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  std::vector<Eigen::Vector2d> previous, current;
  for (int i = 0; i < 40; ++i) {
    previous.emplace_back(u(rng), 0.75 * u(rng));
    current.push_back(previous.back() + Eigen::Vector2d(0.005, 0.003));
  }
  const vims::EpipolarCheck check = vims::epipolarRansac(previous, current, 460.0, 1.0, 0.99, 1000);
  EXPECT_TRUE(check.performed);
  EXPECT_EQ(check.inlier, std::vector<std::uint8_t>(40, 1));
}

TEST(ThinByDistance, LongTracksWinConflicts) {
  cv::Mat occupancy(100, 200, CV_8UC1, cv::Scalar(255));
  // 0 and 1 conflict (10 px apart): 1 is longer and wins. 2 is alone. 3 is outside the image.
  const std::vector<cv::Point2f> pixels = {{50, 50}, {60, 50}, {150, 50}, {-5, 50}};
  const std::vector<int> lengths = {2, 9, 1, 30};
  const std::vector<std::size_t> kept = vims::thinByDistanceLongestFirst(pixels, lengths, 30.0, &occupancy);
  EXPECT_EQ(kept, (std::vector<std::size_t>{1, 2}));
  EXPECT_EQ(occupancy.at<std::uint8_t>(50, 60), 0);
  EXPECT_EQ(occupancy.at<std::uint8_t>(50, 100), 255);
}

TEST(SelectCorners, LowersQualityOnlyWhenTooFewCorners) {
  vims::CornerCandidates candidates;
  candidates.max_response = 1.0f;
  // One strong corner and weak ones at 1e-3 of it, well spread.
  candidates.candidates.push_back({cv::Point2f(10, 10), 1.0f});
  for (int i = 0; i < 9; ++i) candidates.candidates.push_back({cv::Point2f(50.0f + 40.0f * i, 60), 1e-3f});
  vims::CornerSelectionParams params;
  params.max_corners = 5;
  params.min_distance_px = 20;
  params.quality_level = 0.01;
  params.min_quality_level = 0.0005;
  params.quality_decrease_factor = 0.25;

  cv::Mat occupancy(120, 420, CV_8UC1, cv::Scalar(255));
  vims::CornerSelection selection = vims::selectCorners(candidates, params, &occupancy);
  EXPECT_EQ(selection.corners.size(), 5u);
  EXPECT_LT(selection.quality_level_reached, 0.01);
  EXPECT_GE(selection.quality_level_reached, 0.0005);

  // Without room for adaptation only the strong corner passes.
  params.min_quality_level = params.quality_level;
  occupancy.setTo(255);
  selection = vims::selectCorners(candidates, params, &occupancy);
  EXPECT_EQ(selection.corners.size(), 1u);

  // Enough strong corners: the level stays where it was.
  params.max_corners = 1;
  occupancy.setTo(255);
  selection = vims::selectCorners(candidates, params, &occupancy);
  EXPECT_DOUBLE_EQ(selection.quality_level_reached, 0.01);
}

TEST(FindCornerCandidates, FlatImageHasNoneAndCheckerboardHasMany) {
  const cv::Mat flat(120, 160, CV_8UC1, cv::Scalar(90));
  EXPECT_TRUE(vims::findCornerCandidates(flat, 5, 1e-5, 0.0005).candidates.empty());
  cv::Mat board(120, 160, CV_8UC1);
  for (int y = 0; y < board.rows; ++y)
    for (int x = 0; x < board.cols; ++x) board.at<std::uint8_t>(y, x) = ((x / 20 + y / 20) % 2) ? 200 : 40;
  const vims::CornerCandidates candidates = vims::findCornerCandidates(board, 5, 1e-5, 0.0005);
  EXPECT_GE(candidates.candidates.size(), 35u);  // 7 x 5 inner corners
  for (const vims::CornerCandidate& c : candidates.candidates) {
    EXPECT_GE(c.response, 0.0005 * candidates.max_response);
    EXPECT_GE(c.pixel.x, 5);
    EXPECT_LT(c.pixel.x, 155);
  }
  // A mask restricts where candidates are kept, not the strongest response they are relative to.
  cv::Mat left_half(board.size(), CV_8UC1, cv::Scalar(0));
  left_half.colRange(0, 80).setTo(255);
  const vims::CornerCandidates masked = vims::findCornerCandidates(board, 5, 1e-5, 0.0005, left_half);
  EXPECT_FLOAT_EQ(masked.max_response, candidates.max_response);
  EXPECT_LT(masked.candidates.size(), candidates.candidates.size());
  for (const vims::CornerCandidate& c : masked.candidates) EXPECT_LT(c.pixel.x, 80);
}

TEST(ShiTomasiResponse, MatchesOpenCvCornerMinEigenValInsideTheRoi) {
  // Smoothed noise plus a few hard edges and corners: every kind of structure tensor.
  cv::Mat image(97, 131, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.2);
  cv::rectangle(image, cv::Rect(30, 20, 40, 30), cv::Scalar(250), cv::FILLED);
  image.rowRange(70, 80).setTo(3);
  cv::Mat expected;
  cv::cornerMinEigenVal(image, expected, 3, 3);
  const cv::Rect roi(2, 3, 120, 90);
  cv::Mat response(image.size(), CV_32FC1, cv::Scalar(-7.0f));
  vims::CornerResponseBuffers buffers;
  vims::shiTomasiResponse(image, roi, &response, &buffers);
  double expected_max = 0.0, strongest = 0.0;
  cv::minMaxLoc(expected(roi), nullptr, &expected_max);
  cv::minMaxLoc(response(roi), nullptr, &strongest);
  ASSERT_GT(expected_max, 1e-3);
  EXPECT_NEAR(strongest, expected_max, 1e-5 * expected_max);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const float got = response.at<float>(y, x);
      if (!roi.contains(cv::Point(x, y))) {
        ASSERT_EQ(got, -7.0f) << "outside the roi at " << x << "," << y;
        continue;
      }
      // OpenCV works in float with a cancelling formula: agree to its rounding.
      ASSERT_NEAR(got, expected.at<float>(y, x), 1e-6 * expected_max + 1e-4 * std::abs(expected.at<float>(y, x)))
          << "at " << x << "," << y;
    }
  }
  EXPECT_THROW(vims::shiTomasiResponse(image, cv::Rect(1, 3, 20, 20), &response, &buffers), std::invalid_argument);
  EXPECT_THROW(vims::shiTomasiResponse(image, cv::Rect(100, 3, 30, 20), &response, &buffers), std::invalid_argument);
}

TEST(FindCornerCandidates, CandidatesAreTheLocalMaximaOfOpenCvsResponse) {
  cv::Mat image(90, 120, CV_8UC1);
  cv::RNG rng(11);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(7, 7), 2.0);
  const int border = 6;
  const vims::CornerCandidates found = vims::findCornerCandidates(image, border, 1e-5, 0.01);
  cv::Mat expected, local_max;
  cv::cornerMinEigenVal(image, expected, 3, 3);
  cv::dilate(expected, local_max, cv::Mat());
  const cv::Rect inner(border, border, image.cols - 2 * border, image.rows - 2 * border);
  double strongest = 0.0;
  cv::minMaxLoc(expected(inner), nullptr, &strongest);
  const double threshold = std::max(1e-5, 0.01 * strongest);
  std::size_t clear_maxima = 0;  // far from the threshold and from a tie with a neighbour
  for (int y = inner.y; y < inner.y + inner.height; ++y) {
    for (int x = inner.x; x < inner.x + inner.width; ++x) {
      const float r = expected.at<float>(y, x);
      if (r == local_max.at<float>(y, x) && r > 1.001 * threshold) {
        ++clear_maxima;
        const bool listed = std::any_of(found.candidates.begin(), found.candidates.end(),
                                        [&](const vims::CornerCandidate& c) { return c.pixel == cv::Point2f(x, y); });
        EXPECT_TRUE(listed) << "local maximum at " << x << "," << y << " missing";
      }
    }
  }
  EXPECT_GT(clear_maxima, 10u);
  EXPECT_LE(found.candidates.size(), clear_maxima + 3);  // near-ties may differ in rounding
}

TEST(SelectCorners, SelectionIsStrongestFirstAndIndependentOfCandidateOrder) {
  vims::CornerCandidates forward;
  forward.max_response = 1.0f;
  for (int i = 0; i < 20; ++i) forward.candidates.push_back({cv::Point2f(10.0f + 30.0f * i, 20), 0.05f * (i % 7 + 1)});
  vims::CornerCandidates backward = forward;
  std::reverse(backward.candidates.begin(), backward.candidates.end());
  vims::CornerSelectionParams params;
  params.max_corners = 8;
  params.min_distance_px = 5;
  cv::Mat occupancy_a(40, 640, CV_8UC1, cv::Scalar(255)), occupancy_b = occupancy_a.clone();
  const auto a = vims::selectCorners(forward, params, &occupancy_a).corners;
  const auto b = vims::selectCorners(backward, params, &occupancy_b).corners;
  EXPECT_EQ(a, b);
  ASSERT_EQ(a.size(), 8u);
  EXPECT_EQ(a.front(), cv::Point2f(10.0f + 30.0f * 6, 20));  // response 0.35, first in raster order
}

namespace {
/// A lamp fixed to the camera: bright on the axis, 1/4 of it in the corners (smooth).
cv::Mat lampField(cv::Size size) {
  cv::Mat lamp(size, CV_32F);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const double r2 = (std::pow(x - 0.5 * size.width, 2) + std::pow(y - 0.5 * size.height, 2)) / std::pow(400.0, 2);
      lamp.at<float>(y, x) = static_cast<float>(1.0 / std::pow(1.0 + r2, 2));
    }
  return lamp;
}

cv::Scalar meanAndStd(const cv::Mat& image, const cv::Rect& roi, double* stddev) {
  cv::Scalar mean, sd;
  cv::meanStdDev(image(roi), mean, sd);
  *stddev = sd[0];
  return mean;
}
}  // namespace

// Flattening divides out the lamp: a uniform floor comes out at the target grey level everywhere,
// corners included (the border mean is taken over the image only), and a textured floor keeps
// the same contrast in the dark corners as on the bright axis.
TEST(FlattenIllumination, RemovesACameraFixedLampAndEqualisesContrast) {
  const cv::Size size(640, 480);
  const cv::Mat lamp = lampField(size);
  cv::Mat uniform;
  cv::Mat(200.0f * lamp).convertTo(uniform, CV_8U);
  vims::IlluminationBuffers buffers;
  cv::Mat flat;
  vims::flattenIllumination(uniform, 20.0, 8, 128.0, &flat, &buffers);
  ASSERT_EQ(flat.type(), CV_8UC1);
  ASSERT_EQ(flat.size(), size);
  double min_value = 0.0, max_value = 0.0;
  cv::minMaxLoc(flat, &min_value, &max_value);
  // Within 12 %: at the very corner the mean over the image only leans towards the brighter inside.
  EXPECT_GT(min_value, 128.0 * 0.88) << "the input ranges over 40..200";
  EXPECT_LT(max_value, 128.0 * 1.12);

  // Texture: +-30 % albedo checks of 8 px under the same lamp.
  cv::Mat albedo(size, CV_32F);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) albedo.at<float>(y, x) = ((x / 8 + y / 8) % 2) ? 1.3f : 0.7f;
  cv::Mat textured;
  cv::Mat(150.0f * albedo.mul(lamp)).convertTo(textured, CV_8U);
  vims::flattenIllumination(textured, 20.0, 8, 128.0, &flat, &buffers);
  const cv::Rect centre(288, 208, 64, 64), corner(8, 8, 64, 64);
  double sd_centre_in = 0.0, sd_corner_in = 0.0, sd_centre = 0.0, sd_corner = 0.0;
  meanAndStd(textured, centre, &sd_centre_in);
  meanAndStd(textured, corner, &sd_corner_in);
  const double mean_centre = meanAndStd(flat, centre, &sd_centre)[0];
  const double mean_corner = meanAndStd(flat, corner, &sd_corner)[0];
  ASSERT_GT(sd_centre_in, 2.5 * sd_corner_in) << "the lamp darkens the corner";
  EXPECT_NEAR(mean_centre, 128.0, 6.0);
  EXPECT_NEAR(mean_corner, 128.0, 12.0);
  EXPECT_NEAR(sd_corner / sd_centre, 1.0, 0.25) << "centre " << sd_centre << ", corner " << sd_corner;
}
