#include <gtest/gtest.h>

#include "vims_tracking/feature_drawing.h"

namespace {

vims::TrackedFeature featureAt(double x, double y, int length) {
  vims::TrackedFeature f;
  f.pixel = Eigen::Vector2d(x, y);
  f.track_length = length;
  f.pixel_velocity = Eigen::Vector2d(50, 0);
  return f;
}

}  // namespace

TEST(FeatureDrawing, ColoursGoFromBlueForNewToRedForLongTracks) {
  const cv::Scalar fresh = vims::trackLengthColour(1, 20);
  const cv::Scalar old = vims::trackLengthColour(40, 20);
  EXPECT_EQ(fresh, cv::Scalar(255, 0, 0));
  EXPECT_EQ(old, cv::Scalar(0, 0, 255));
  const cv::Scalar middle = vims::trackLengthColour(10, 20);
  EXPECT_GT(middle[0], 0);
  EXPECT_GT(middle[2], 0);
}

TEST(FeatureDrawing, DrawsOnAColourCopyOfTheImage) {
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(100));
  vims::TrackedFrame frame;
  frame.features = {featureAt(100, 100, 1), featureAt(300, 200, 30)};
  const cv::Mat drawn = vims::drawTrackedFeatures(grey, frame);
  ASSERT_EQ(drawn.type(), CV_8UC3);
  ASSERT_EQ(drawn.size(), grey.size());
  // The circle of radius 3 passes through (x + 3, y).
  const cv::Vec3b blue = drawn.at<cv::Vec3b>(100, 103);
  const cv::Vec3b red = drawn.at<cv::Vec3b>(200, 303);
  EXPECT_GT(blue[0], 150);
  EXPECT_LT(blue[2], 100);
  EXPECT_GT(red[2], 150);
  EXPECT_LT(red[0], 100);
  EXPECT_EQ(grey.at<std::uint8_t>(100, 103), 100) << "input untouched";
}

TEST(FeatureDrawing, NeverThrowsOnBadImages) {
  vims::TrackedFrame frame;
  frame.features = {featureAt(10, 10, 2), featureAt(std::nan(""), 5, 3), featureAt(1e9, -1e9, 4)};
  EXPECT_EQ(vims::drawTrackedFeatures(cv::Mat(), frame).type(), CV_8UC3);
  EXPECT_EQ(vims::drawTrackedFeatures(cv::Mat(48, 64, CV_16UC1), frame).size(), cv::Size(64, 48));
}
