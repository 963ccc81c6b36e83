#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>

#include "vims_eval/plot.h"

using namespace vims::eval;

namespace {

/// Pixels whose colour is within `tol` of `color` (BGR).
int countColor(const cv::Mat& image, const cv::Scalar& color, int tol = 40) {
  int n = 0;
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c) {
      const cv::Vec3b px = image.at<cv::Vec3b>(r, c);
      if (std::abs(px[0] - color[0]) <= tol && std::abs(px[1] - color[1]) <= tol && std::abs(px[2] - color[2]) <= tol)
        ++n;
    }
  return n;
}

int countNonWhite(const cv::Mat& image) {
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  return cv::countNonZero(gray < 250);
}

}  // namespace

TEST(Plot, NiceTicks) {
  EXPECT_EQ(niceTicks(0.0, 10.0, 5), (std::vector<double>{0, 2, 4, 6, 8, 10}));
  const auto ticks = niceTicks(-0.13, 0.41, 6);
  ASSERT_FALSE(ticks.empty());
  EXPECT_NEAR(ticks[1] - ticks[0], 0.1, 1e-12);
  EXPECT_GE(ticks.front(), -0.13);
  EXPECT_LE(ticks.back(), 0.41);
  EXPECT_TRUE(niceTicks(1.0, 1.0).empty());
}

TEST(Plot, TopViewWrittenAndReadBack) {
  std::vector<double> xs, ys;
  for (int i = 0; i <= 200; ++i) {
    const double a = 2 * M_PI * i / 200.0;
    xs.push_back(10.0 * std::cos(a));
    ys.push_back(3.0 * std::sin(a));
  }
  Plot2D plot(640, 480);
  plot.setTitle("ellipse").setAxisLabels("x [m]", "y [m]").setEqualAspect(true);
  plot.addLine(xs, ys, plotColor(3), "path", 2);
  plot.addScatter({10.0}, {0.0}, plotColor(2), "start", 6, MarkerShape::kSquare);
  plot.addSegments({-10.0}, {0.0}, {0.0}, {3.0}, plotColor(0), "link");
  const std::string path = ::testing::TempDir() + "/vims_eval_plot.png";
  plot.savePng(path);

  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 640);
  EXPECT_EQ(image.rows, 480);
  EXPECT_GT(countNonWhite(image), 2000);            // axes, ticks, text, curve
  EXPECT_GT(countColor(image, plotColor(3)), 300);  // the red ellipse is drawn
  EXPECT_GT(countColor(image, plotColor(2)), 50);   // the green start marker
  // Equal aspect: the ellipse's pixel width / height is its data ratio 10 / 3.
  int min_c = image.cols, max_c = 0, min_r = image.rows, max_r = 0;
  const cv::Scalar red = plotColor(3);
  for (int r = 0; r < image.rows; ++r)
    for (int c = 0; c < image.cols; ++c) {
      const cv::Vec3b px = image.at<cv::Vec3b>(r, c);
      if (std::abs(px[0] - red[0]) < 20 && std::abs(px[1] - red[1]) < 20 && std::abs(px[2] - red[2]) < 20) {
        // Skip the legend sample (top-right box): only the curve inside the axes counts.
        if (r < 110 && c > 440) continue;
        min_c = std::min(min_c, c), max_c = std::max(max_c, c);
        min_r = std::min(min_r, r), max_r = std::max(max_r, r);
      }
    }
  EXPECT_NEAR(static_cast<double>(max_c - min_c) / (max_r - min_r), 10.0 / 3.0, 0.25);
}

TEST(Plot, HeatmapMatrixWithColorbar) {
  cv::Mat values(20, 30, CV_64FC1);
  for (int r = 0; r < values.rows; ++r)
    for (int c = 0; c < values.cols; ++c) values.at<double>(r, c) = r + c;
  values.at<double>(0, 0) = std::nan("");  // drawn in the invalid colour
  Plot2D plot(700, 500);
  HeatmapStyle style;
  style.colorbar_label = "score";
  plot.setTitle("matrix").setAxisLabels("match", "query").setInvertY(true);
  plot.setHeatmap(values, 0, 30, 0, 20, style);
  const std::string path = ::testing::TempDir() + "/vims_eval_heatmap.png";
  plot.savePng(path);
  const cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_EQ(image.size(), cv::Size(700, 500));
  // Most of the axes area is coloured, and low and high values get different colours.
  EXPECT_GT(countNonWhite(image), 700 * 500 / 3);
  const cv::Vec3b centre = image.at<cv::Vec3b>(250, 330);
  EXPECT_FALSE(centre == cv::Vec3b(255, 255, 255));
  EXPECT_GT(countColor(image, cv::Scalar(200, 200, 200), 3), 20);  // the NaN cell
  EXPECT_THROW(plot.setHeatmap(cv::Mat(3, 3, CV_8UC1), 0, 1, 0, 1), std::invalid_argument);
}

TEST(Plot, RejectsBadInput) {
  Plot2D plot;
  EXPECT_THROW(plot.addLine({1, 2}, {1}, plotColor(0)), std::invalid_argument);
  EXPECT_THROW(plot.setXRange(1.0, 1.0), std::invalid_argument);
  EXPECT_THROW(Plot2D(10, 10), std::invalid_argument);
  EXPECT_THROW(plot.savePng("/nonexistent_dir/x.png"), std::runtime_error);
  // An empty plot and one with only NaN still render.
  plot.addLine({std::nan("")}, {1.0}, plotColor(1), "nan");
  EXPECT_EQ(plot.render().cols, 900);
}
