#include <gtest/gtest.h>

#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "vims_ros/conversions.h"

TEST(Conversions, ImuRejectsNaNAndKeepsValues) {
  sensor_msgs::Imu msg;
  msg.header.stamp = ros::Time(100, 500000000);
  msg.angular_velocity.z = 0.1;
  msg.linear_acceleration.z = 9.81;
  vims::ImuSample s;
  std::string why;
  ASSERT_TRUE(vims::toImuSample(msg, &s, &why));
  EXPECT_DOUBLE_EQ(s.t, 100.5);
  EXPECT_DOUBLE_EQ(s.accel.z(), 9.81);
  msg.linear_acceleration.x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(vims::toImuSample(msg, &s, &why));
  EXPECT_NE(why.find("linear_acceleration"), std::string::npos);
}

TEST(Conversions, SonarKeepsInfAsDropoutRejectsNaN) {
  sensor_msgs::Range msg;
  msg.range = std::numeric_limits<float>::infinity();
  vims::SonarRange r;
  std::string why;
  ASSERT_TRUE(vims::toSonarRange(msg, &r, &why));
  EXPECT_TRUE(std::isinf(r.range));
  msg.range = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(vims::toSonarRange(msg, &r, &why));
}

TEST(Conversions, MagRejectsInf) {
  sensor_msgs::MagneticField msg;
  msg.magnetic_field.x = 2e-5;
  vims::MagSample m;
  std::string why;
  ASSERT_TRUE(vims::toMagSample(msg, &m, &why));
  msg.magnetic_field.y = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(vims::toMagSample(msg, &m, &why));
}

namespace {
sensor_msgs::Image makeImage(const std::string& enc, int w, int h, int channels) {
  sensor_msgs::Image img;
  img.encoding = enc;
  img.width = w;
  img.height = h;
  img.step = w * channels;
  img.data.assign(img.step * h, 0);
  return img;
}
}  // namespace

TEST(Conversions, ImageEncodingsSizeAndCorruptBuffers) {
  vims::CameraFrame f;
  std::string why;
  auto mono = makeImage("mono8", 4, 3, 1);
  mono.data[5] = 200;
  ASSERT_TRUE(vims::toCameraFrame(mono, 4, 3, &f, &why)) << why;
  EXPECT_EQ(f.image.type(), CV_8UC1);
  EXPECT_EQ(f.image.at<uint8_t>(1, 1), 200);
  // The converted frame owns its pixels.
  mono.data[5] = 0;
  EXPECT_EQ(f.image.at<uint8_t>(1, 1), 200);

  auto bgr = makeImage("bgr8", 4, 3, 3);
  std::fill(bgr.data.begin(), bgr.data.end(), 100);
  ASSERT_TRUE(vims::toCameraFrame(bgr, 4, 3, &f, &why));
  EXPECT_EQ(f.image.channels(), 1);
  EXPECT_EQ(f.image.at<uint8_t>(0, 0), 100);

  EXPECT_FALSE(vims::toCameraFrame(makeImage("yuv422", 4, 3, 2), 4, 3, &f, &why));
  EXPECT_NE(why.find("yuv422"), std::string::npos);
  EXPECT_FALSE(vims::toCameraFrame(makeImage("mono8", 4, 3, 1), 640, 480, &f, &why));
  EXPECT_FALSE(vims::toCameraFrame(makeImage("mono8", 0, 0, 1), -1, -1, &f, &why));
  auto truncated = makeImage("mono8", 4, 3, 1);
  truncated.data.resize(5);
  EXPECT_FALSE(vims::toCameraFrame(truncated, 4, 3, &f, &why));
  EXPECT_NE(why.find("bytes"), std::string::npos);
}

namespace {

/// A 40x30 test pattern; colour images get the same pattern in three channels with offsets.
cv::Mat pattern(int type) {
  cv::Mat image(30, 40, type);
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      const int v = (7 * r + 13 * c) % 256;
      if (type == CV_8UC1) image.at<uint8_t>(r, c) = static_cast<uint8_t>(v);
      if (type == CV_8UC3) image.at<cv::Vec3b>(r, c) = cv::Vec3b(v, (v + 80) % 256, (v + 160) % 256);
    }
  }
  return image;
}

sensor_msgs::CompressedImage compressed(const cv::Mat& image, const std::string& ext, const std::string& format) {
  sensor_msgs::CompressedImage msg;
  msg.header.stamp = ros::Time(12.5);
  msg.format = format;
  EXPECT_TRUE(cv::imencode(ext, image, msg.data));
  return msg;
}

}  // namespace

TEST(Conversions, CompressedImagesDecodeAsTheirRawTwins) {
  vims::CameraFrame frame;
  std::string why;
  // png is lossless: mono comes back to the bit, colour as the raw bgr8 path makes it grey.
  const cv::Mat mono = pattern(CV_8UC1);
  ASSERT_TRUE(vims::toCameraFrame(compressed(mono, ".png", "png"), 40, 30, &frame, &why)) << why;
  EXPECT_EQ(cv::norm(frame.image, mono, cv::NORM_INF), 0.0);
  EXPECT_DOUBLE_EQ(frame.t, 12.5);
  const cv::Mat bgr = pattern(CV_8UC3);
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  ASSERT_TRUE(vims::toCameraFrame(compressed(bgr, ".png", "bgr8; png compressed bgr8"), 40, 30, &frame, &why)) << why;
  EXPECT_EQ(cv::norm(frame.image, grey, cv::NORM_INF), 0.0);
  // jpeg (OpenCV's default quality 95) loses a little: 0.70 grey levels mean error measured.
  ASSERT_TRUE(vims::toCameraFrame(compressed(mono, ".jpg", "jpeg"), 40, 30, &frame, &why)) << why;
  EXPECT_EQ(frame.image.type(), CV_8UC1);
  EXPECT_LT(cv::norm(frame.image, mono, cv::NORM_L1) / mono.total(), 1.4);
}

TEST(Conversions, BadCompressedImagesAreRejectedWithAReason) {
  vims::CameraFrame frame;
  std::string why;
  const cv::Mat mono = pattern(CV_8UC1);
  EXPECT_FALSE(vims::toCameraFrame(compressed(mono, ".bmp", "bmp"), 40, 30, &frame, &why));
  EXPECT_NE(why.find("unsupported compressed image format 'bmp'"), std::string::npos) << why;
  EXPECT_FALSE(vims::toCameraFrame(compressed(mono, ".png", "png"), 640, 480, &frame, &why));
  EXPECT_NE(why.find("calibration says 640x480"), std::string::npos) << why;
  sensor_msgs::CompressedImage corrupt = compressed(mono, ".png", "png");
  corrupt.data.resize(20);
  EXPECT_FALSE(vims::toCameraFrame(corrupt, 40, 30, &frame, &why));
  corrupt.data.clear();
  EXPECT_FALSE(vims::toCameraFrame(corrupt, 40, 30, &frame, &why));
}
