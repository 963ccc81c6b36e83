// Precision-recall curves, F0.5 and recognition matrices of the place-recognition evaluation.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>

#include "vims_eval/place_recognition.h"

namespace fs = std::filesystem;
using namespace vims::eval;

namespace {
constexpr float kNever = -std::numeric_limits<float>::infinity();
}

TEST(PlaceRecognitionMetrics, FBeta) {
  EXPECT_DOUBLE_EQ(fBeta(1.0, 1.0, 0.5), 1.0);
  EXPECT_DOUBLE_EQ(fBeta(0.0, 0.0, 0.5), 0.0);
  // F0.5 weighs precision more: (1.25 * 1 * 0.5) / (0.25 * 1 + 0.5) = 5/6.
  EXPECT_NEAR(fBeta(1.0, 0.5, 0.5), 5.0 / 6.0, 1e-12);
  EXPECT_NEAR(fBeta(0.5, 1.0, 0.5), 0.625 / 1.125, 1e-12);
  EXPECT_NEAR(fBeta(0.5, 1.0, 1.0), 2.0 / 3.0, 1e-12);
}

TEST(PlaceRecognitionMetrics, CurveByHand) {
  // Sorted: 0.9 T, 0.8 F, 0.7 T, 0.7 F (tie: one threshold), 0.6 F; -inf T is never recognised.
  const std::vector<float> scores = {0.7f, 0.9f, 0.6f, 0.8f, kNever, 0.7f};
  const std::vector<uint8_t> truth = {1, 1, 0, 0, 1, 0};
  const PrCurve c = computePrCurve("m", scores, truth);
  EXPECT_EQ(c.pairs, 6u);
  EXPECT_EQ(c.positives, 3u);
  ASSERT_EQ(c.points.size(), 4u);
  EXPECT_FLOAT_EQ(c.points[0].threshold, 0.9f);
  EXPECT_DOUBLE_EQ(c.points[0].precision, 1.0);
  EXPECT_DOUBLE_EQ(c.points[0].recall, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(c.points[1].precision, 0.5);
  EXPECT_FLOAT_EQ(c.points[2].threshold, 0.7f);
  EXPECT_EQ(c.points[2].tp, 2u);
  EXPECT_EQ(c.points[2].fp, 2u);
  EXPECT_DOUBLE_EQ(c.points[2].recall, 2.0 / 3.0);
  EXPECT_EQ(c.points[3].fp, 3u);
  // F0.5: 0.9 -> 1.25 * (1/3) / (0.25 + 1/3) = 0.714; 0.7 -> 0.5 * 2/3 * 1.25 / (0.125 + 2/3) = 0.526.
  EXPECT_NEAR(c.best_f05, 1.25 * (1.0 / 3.0) / (0.25 + 1.0 / 3.0), 1e-9);
  EXPECT_FLOAT_EQ(c.best.threshold, 0.9f);
}

TEST(PlaceRecognitionMetrics, NothingRecognisableGivesZeroAndInfiniteThreshold) {
  const PrCurve c = computePrCurve("m", {kNever, kNever}, {1, 0});
  EXPECT_TRUE(c.points.empty());
  EXPECT_EQ(c.best_f05, 0.0);
  EXPECT_TRUE(std::isinf(c.best.threshold));
  EXPECT_THROW(computePrCurve("m", {0.1f}, {1, 0}), std::invalid_argument);
}

TEST(PlaceRecognitionMetrics, OutcomeMatrixCells) {
  const std::vector<std::pair<uint32_t, uint32_t>> pairs = {{3, 0}, {3, 1}, {4, 0}, {4, 1}};
  const std::vector<float> scores = {0.9f, 0.9f, 0.1f, kNever};
  const std::vector<uint8_t> truth = {1, 0, 1, 0};
  const cv::Mat m = outcomeMatrix(5, pairs, scores, truth, 0.5);
  ASSERT_EQ(m.rows, 5);
  auto at = [&](int x, int y) { return static_cast<PairOutcome>(m.at<uint8_t>(y, x)); };
  EXPECT_EQ(at(3, 0), PairOutcome::kTruePositive);
  EXPECT_EQ(at(3, 1), PairOutcome::kFalsePositive);
  EXPECT_EQ(at(4, 0), PairOutcome::kFalseNegative);
  EXPECT_EQ(at(4, 1), PairOutcome::kTrueNegative);
  EXPECT_EQ(at(1, 3), PairOutcome::kExcluded);
  EXPECT_THROW(outcomeMatrix(3, pairs, scores, truth, 0.5), std::out_of_range);
}

TEST(PlaceRecognitionMetrics, MatrixPngShowsEachOutcomeColour) {
  // 1200 keyframes: drawn in 2x2 blocks; a single true positive cell must stay visible.
  const int n = 1200;
  cv::Mat m(n, n, CV_8UC1, cv::Scalar(static_cast<int>(PairOutcome::kExcluded)));
  for (int x = 50; x < n; ++x)
    for (int y = 0; y + 50 <= x; ++y) m.at<uint8_t>(y, x) = static_cast<uint8_t>(PairOutcome::kTrueNegative);
  m.at<uint8_t>(10, 900) = static_cast<uint8_t>(PairOutcome::kTruePositive);
  m.at<uint8_t>(11, 600) = static_cast<uint8_t>(PairOutcome::kFalsePositive);
  const std::string path = (fs::path(VIMS_BINARY_DIR) / "test_recognition_matrix.png").string();
  writeOutcomeMatrixPng(m, "test", path);
  const cv::Mat img = cv::imread(path);
  ASSERT_FALSE(img.empty());
  int green = 0, red = 0;
  for (int r = 0; r < img.rows; ++r)
    for (int c = 0; c < img.cols - 200; ++c) {  // the plot area, not the legend
      const cv::Vec3b px = img.at<cv::Vec3b>(r, c);
      green += (px == cv::Vec3b(44, 160, 44));
      red += (px == cv::Vec3b(40, 39, 214));
    }
  EXPECT_GT(green, 0);
  EXPECT_GT(red, 0);
  EXPECT_THROW(writeOutcomeMatrixPng(cv::Mat(3, 4, CV_8UC1), "x", path), std::invalid_argument);
}
