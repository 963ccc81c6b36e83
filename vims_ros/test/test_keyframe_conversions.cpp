#include <gtest/gtest.h>

#include <limits>

#include "vims_ros/keyframe_conversions.h"

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

vims::KeyframeData makeKeyframe() {
  vims::KeyframeData keyframe;
  keyframe.t = 1234.25;
  keyframe.session = 3;
  keyframe.T_odom_b.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.3, 1.0).normalized()).toRotationMatrix();
  keyframe.T_odom_b.translation() = Eigen::Vector3d(1.5, -2.0, -3.25);
  for (int i = 0; i < 3; ++i) {
    vims::KeyframeLandmark feature;
    feature.id = 1000u + static_cast<std::uint64_t>(i);
    feature.p_odom = Eigen::Vector3d(0.5 * i, -1.0, -5.0 + i);
    feature.pixel = Eigen::Vector2d(100.5 + i, 200.25);
    feature.normalized = Eigen::Vector2d(-0.125 * i, 0.25);
    keyframe.features.push_back(feature);
  }
  keyframe.image = cv::Mat(4, 6, CV_8UC1);
  for (int r = 0; r < keyframe.image.rows; ++r) {
    for (int c = 0; c < keyframe.image.cols; ++c) keyframe.image.at<uint8_t>(r, c) = static_cast<uint8_t>(10 * r + c);
  }
  return keyframe;
}

vims::Keyframe makeKeyframeMsg() {
  vims::Keyframe msg;
  std::string why;
  EXPECT_TRUE(vims::toKeyframeMsg(makeKeyframe(), "odom", &msg, &why)) << why;
  return msg;
}

}  // namespace

TEST(KeyframeConversions, RoundTripKeepsEverything) {
  const vims::KeyframeData original = makeKeyframe();
  vims::Keyframe msg;
  std::string why;
  ASSERT_TRUE(vims::toKeyframeMsg(original, "odom", &msg, &why)) << why;
  EXPECT_EQ(msg.header.frame_id, "odom");
  EXPECT_EQ(msg.image.encoding, "mono8");
  EXPECT_EQ(msg.image.step, 6u);

  vims::KeyframeData back;
  ASSERT_TRUE(vims::toKeyframeData(msg, &back, &why)) << why;
  EXPECT_NEAR(back.t, original.t, 1e-9);
  EXPECT_EQ(back.session, original.session);
  EXPECT_TRUE(back.T_odom_b.isApprox(original.T_odom_b, 1e-12));
  EXPECT_FALSE(back.T_b_c.has_value());
  ASSERT_EQ(back.features.size(), original.features.size());
  for (size_t i = 0; i < original.features.size(); ++i) {
    EXPECT_EQ(back.features[i].id, original.features[i].id);
    EXPECT_TRUE(back.features[i].p_odom.isApprox(original.features[i].p_odom));
    EXPECT_NEAR((back.features[i].pixel - original.features[i].pixel).norm(), 0.0, 1e-4);  // float32 in the message
    EXPECT_NEAR((back.features[i].normalized - original.features[i].normalized).norm(), 0.0, 1e-6);
  }
  ASSERT_EQ(back.image.type(), CV_8UC1);
  EXPECT_EQ(cv::countNonZero(back.image != original.image), 0);
}

TEST(KeyframeConversions, EmptyImageGivesEmptyMat) {
  vims::KeyframeData keyframe = makeKeyframe();
  keyframe.image = cv::Mat();
  vims::Keyframe msg;
  std::string why;
  ASSERT_TRUE(vims::toKeyframeMsg(keyframe, "odom", &msg, &why)) << why;
  EXPECT_EQ(msg.image.width, 0u);
  vims::KeyframeData back;
  ASSERT_TRUE(vims::toKeyframeData(msg, &back, &why)) << why;
  EXPECT_TRUE(back.image.empty());
}

TEST(KeyframeConversions, ColourImageBecomesGrey) {
  vims::KeyframeData keyframe = makeKeyframe();
  keyframe.image = cv::Mat(4, 6, CV_8UC3, cv::Scalar(50, 50, 50));
  vims::Keyframe msg;
  std::string why;
  ASSERT_TRUE(vims::toKeyframeMsg(keyframe, "odom", &msg, &why)) << why;
  EXPECT_EQ(msg.image.encoding, "bgr8");
  vims::KeyframeData back;
  ASSERT_TRUE(vims::toKeyframeData(msg, &back, &why)) << why;
  ASSERT_EQ(back.image.type(), CV_8UC1);
  EXPECT_EQ(back.image.at<uint8_t>(2, 3), 50);
}

TEST(KeyframeConversions, RejectsNaNPoseAndPoints) {
  std::string why;
  vims::KeyframeData out;

  vims::Keyframe msg = makeKeyframeMsg();
  msg.pose.position.y = kNaN;
  EXPECT_FALSE(vims::toKeyframeData(msg, &out, &why));
  EXPECT_NE(why.find("position"), std::string::npos) << why;

  msg = makeKeyframeMsg();
  msg.pose.orientation.w = kNaN;
  EXPECT_FALSE(vims::toKeyframeData(msg, &out, &why));
  EXPECT_NE(why.find("orientation"), std::string::npos) << why;

  msg = makeKeyframeMsg();
  msg.pose.orientation.w = 0.0;
  msg.pose.orientation.x = 0.0;
  msg.pose.orientation.y = 0.0;
  msg.pose.orientation.z = 0.0;
  EXPECT_FALSE(vims::toKeyframeData(msg, &out, &why));
  EXPECT_NE(why.find("unit quaternion"), std::string::npos) << why;

  msg = makeKeyframeMsg();
  msg.features[1].p_odom.z = kNaN;
  EXPECT_FALSE(vims::toKeyframeData(msg, &out, &why));
  EXPECT_NE(why.find("feature 1001"), std::string::npos) << why;

  msg = makeKeyframeMsg();
  msg.features[2].u = std::numeric_limits<float>::infinity();
  EXPECT_FALSE(vims::toKeyframeData(msg, &out, &why));
  EXPECT_NE(why.find("pixel"), std::string::npos) << why;

  vims::KeyframeData keyframe = makeKeyframe();
  keyframe.features[0].p_odom.x() = kNaN;
  vims::Keyframe rejected;
  EXPECT_FALSE(vims::toKeyframeMsg(keyframe, "odom", &rejected, &why));
  keyframe = makeKeyframe();
  keyframe.t = -1.0;
  EXPECT_FALSE(vims::toKeyframeMsg(keyframe, "odom", &rejected, &why));
  EXPECT_NE(why.find("ROS time"), std::string::npos) << why;
}

TEST(KeyframeConversions, RejectsWrongEncodingAndSizes) {
  std::string why;
  vims::KeyframeData out;

  vims::Keyframe msg = makeKeyframeMsg();
  msg.image.encoding = "32FC1";
  EXPECT_FALSE(vims::toKeyframeData(msg, &out, &why));
  EXPECT_NE(why.find("encoding"), std::string::npos) << why;

  msg = makeKeyframeMsg();
  msg.image.data.resize(msg.image.data.size() / 2);
  EXPECT_FALSE(vims::toKeyframeData(msg, &out, &why));
  EXPECT_NE(why.find("image"), std::string::npos) << why;

  vims::KeyframeData keyframe = makeKeyframe();
  keyframe.image = cv::Mat(4, 6, CV_32FC1, cv::Scalar(0.5));
  vims::Keyframe rejected;
  EXPECT_FALSE(vims::toKeyframeMsg(keyframe, "odom", &rejected, &why));
  EXPECT_NE(why.find("CV_8UC1"), std::string::npos) << why;
}

TEST(KeyframeConversions, PaddedImageRowsAreCopiedCompactly) {
  vims::KeyframeData keyframe = makeKeyframe();
  const cv::Mat content = keyframe.image.clone();
  cv::Mat big(8, 10, CV_8UC1, cv::Scalar(255));
  content.copyTo(big(cv::Rect(2, 1, 6, 4)));
  keyframe.image = big(cv::Rect(2, 1, 6, 4));  // a view with padded rows
  vims::Keyframe msg;
  std::string why;
  ASSERT_TRUE(vims::toKeyframeMsg(keyframe, "odom", &msg, &why)) << why;
  vims::KeyframeData back;
  ASSERT_TRUE(vims::toKeyframeData(msg, &back, &why)) << why;
  EXPECT_EQ(cv::countNonZero(back.image != content), 0);
}

TEST(SignatureConversions, KeepsValuesAndValidity) {
  vims::MagneticSignature msg;
  msg.header.stamp = ros::Time(500.5);
  msg.window_start = ros::Time(499.5);
  msg.window_end = ros::Time(501.5);
  msg.frequency_hz = 12.5;
  msg.amplitude_enu.x = 4e-8;
  msg.amplitude_enu.y = -2e-8;
  msg.amplitude_enu.z = 1e-8;
  msg.geomagnetic_body.x = 2e-5;
  msg.snr = 300.0;
  msg.valid = true;
  vims::SignatureWindow window;
  std::string why;
  ASSERT_TRUE(vims::toSignatureWindow(msg, &window, &why)) << why;
  EXPECT_NEAR(window.t, 500.5, 1e-9);
  EXPECT_NEAR(window.t_start, 499.5, 1e-9);
  EXPECT_NEAR(window.t_end, 501.5, 1e-9);
  EXPECT_DOUBLE_EQ(window.frequency_hz, 12.5);
  EXPECT_TRUE(window.amplitude_enu.isApprox(Eigen::Vector3d(4e-8, -2e-8, 1e-8)));
  EXPECT_DOUBLE_EQ(window.geomagnetic_body.x(), 2e-5);
  EXPECT_DOUBLE_EQ(window.snr, 300.0);
  EXPECT_TRUE(window.valid);

  msg.valid = false;
  ASSERT_TRUE(vims::toSignatureWindow(msg, &window, &why)) << why;
  EXPECT_FALSE(window.valid);
}

TEST(SignatureConversions, NaNRejectedWhenValidZeroedWhenInvalid) {
  vims::MagneticSignature msg;
  msg.header.stamp = ros::Time(10.0);
  msg.window_start = ros::Time(9.0);
  msg.window_end = ros::Time(11.0);
  msg.amplitude_enu.y = kNaN;
  msg.snr = kNaN;
  msg.valid = true;
  vims::SignatureWindow window;
  std::string why;
  EXPECT_FALSE(vims::toSignatureWindow(msg, &window, &why));
  EXPECT_NE(why.find("amplitude_enu"), std::string::npos) << why;

  msg.valid = false;
  ASSERT_TRUE(vims::toSignatureWindow(msg, &window, &why)) << why;
  EXPECT_FALSE(window.valid);
  EXPECT_TRUE(window.amplitude_enu.allFinite());
  EXPECT_TRUE(std::isfinite(window.snr));

  msg.window_start = ros::Time(12.0);
  EXPECT_FALSE(vims::toSignatureWindow(msg, &window, &why));
  EXPECT_NE(why.find("window_start"), std::string::npos) << why;
}

TEST(KeyframeConversions, TheEstimatedCameraExtrinsicRoundTripsAndABadOneIsRejected) {
  vims::KeyframeData keyframe = makeKeyframe();
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
  T_b_c.linear() = Eigen::AngleAxisd(0.02, Eigen::Vector3d(1.0, 0.5, -0.2).normalized()).toRotationMatrix();
  T_b_c.translation() = Eigen::Vector3d(0.25, -0.01, -0.08);
  keyframe.T_b_c = T_b_c;
  vims::Keyframe msg;
  std::string why;
  ASSERT_TRUE(vims::toKeyframeMsg(keyframe, "odom", &msg, &why)) << why;
  EXPECT_TRUE(msg.has_T_b_c);
  vims::KeyframeData back;
  ASSERT_TRUE(vims::toKeyframeData(msg, &back, &why)) << why;
  ASSERT_TRUE(back.T_b_c.has_value());
  EXPECT_TRUE(back.T_b_c->isApprox(T_b_c, 1e-12));

  msg.T_b_c.orientation.w = kNaN;
  EXPECT_FALSE(vims::toKeyframeData(msg, &back, &why));
  EXPECT_NE(why.find("keyframe camera extrinsic"), std::string::npos) << why;
  keyframe.T_b_c->translation().x() = kNaN;
  EXPECT_FALSE(vims::toKeyframeMsg(keyframe, "odom", &msg, &why));
  EXPECT_NE(why.find("camera extrinsic is not finite"), std::string::npos) << why;
}
