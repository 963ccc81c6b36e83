#include <gtest/gtest.h>

#include <limits>

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
