#include <gtest/gtest.h>

#include <cmath>

#include "vims_eval/association.h"

using vims::StampedPose;
using vims::eval::associate;
using vims::eval::AssociationOptions;
using vims::eval::interpolatePose;

namespace {

std::vector<StampedPose> posesAt(const std::vector<double>& stamps) {
  std::vector<StampedPose> poses;
  for (double t : stamps) {
    StampedPose p;
    p.t = t;
    p.p = Eigen::Vector3d(t, 2.0 * t, 0.0);  // position encodes the stamp, to check pairing
    poses.push_back(p);
  }
  return poses;
}

}  // namespace

TEST(Association, NearestStampWithinMaxDiffAndUnmatchedDropped) {
  const auto gt = posesAt({0.0, 0.1, 0.2, 0.3, 0.4, 0.5});
  // 0.105 matches 0.1 (5 ms); 0.22 is 20 ms from 0.2 (dropped); 0.399 matches 0.4; 0.9 beyond the end.
  const auto est = posesAt({0.105, 0.22, 0.399, 0.9});
  const auto a = associate(gt, est, AssociationOptions{});
  ASSERT_EQ(a.size(), 2u);
  EXPECT_DOUBLE_EQ(a.gt[0].t, 0.1);
  EXPECT_DOUBLE_EQ(a.est[0].t, 0.105);
  EXPECT_DOUBLE_EQ(a.gt[1].t, 0.4);
  EXPECT_DOUBLE_EQ(a.est[1].t, 0.399);
  EXPECT_NEAR(a.max_abs_dt_s, 0.005, 1e-12);
  EXPECT_EQ(a.gt_total, 6u);
  EXPECT_EQ(a.est_total, 4u);

  AssociationOptions loose;
  loose.max_dt_s = 0.03;
  EXPECT_EQ(associate(gt, est, loose).size(), 3u);
}

TEST(Association, EachReferenceStampUsedOnceClosestWins) {
  const auto gt = posesAt({1.0, 2.0, 3.0});
  // Both 1.996 and 2.001 pick ground truth 2.0; only the closer one (2.001) is kept.
  const auto est = posesAt({1.996, 2.001});
  const auto a = associate(gt, est, AssociationOptions{});
  ASSERT_EQ(a.size(), 1u);
  EXPECT_DOUBLE_EQ(a.gt[0].t, 2.0);
  EXPECT_DOUBLE_EQ(a.est[0].t, 2.001);
}

TEST(Association, LongerEstimateIteratesOverGroundTruth) {
  std::vector<double> est_stamps, gt_stamps;
  for (int i = 0; i <= 100; ++i) est_stamps.push_back(0.01 * i);       // 100 Hz
  for (int i = 0; i <= 10; ++i) gt_stamps.push_back(0.1 * i + 0.002);  // 10 Hz, 2 ms offset
  const auto a = associate(posesAt(gt_stamps), posesAt(est_stamps), AssociationOptions{});
  ASSERT_EQ(a.size(), 11u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(a.gt[i].t - a.est[i].t, 0.002, 1e-9);
    EXPECT_EQ(a.gt[i].p.x(), a.gt[i].t);  // the pair keeps each side's own pose
    EXPECT_EQ(a.est[i].p.x(), a.est[i].t);
  }
}

TEST(Association, EmptyAssociationThrowsWithSpans) {
  const auto gt = posesAt({0.0, 1.0});
  const auto est = posesAt({100.0, 101.0});
  try {
    associate(gt, est, AssociationOptions{});
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no estimate stamp"), std::string::npos) << e.what();
  }
  EXPECT_THROW(associate({}, est, AssociationOptions{}), std::runtime_error);
}

TEST(Association, InterpolatesGroundTruthLinearAndSlerp) {
  std::vector<StampedPose> gt(3);
  gt[0].t = 0.0;
  gt[1].t = 1.0;
  gt[1].p = Eigen::Vector3d(1.0, 0.0, 2.0);
  gt[1].q = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  gt[2].t = 3.0;  // 2 s gap to the previous sample
  gt[2].p = Eigen::Vector3d(5.0, 0.0, 0.0);

  const auto mid = interpolatePose(gt, 0.25, 0.5 + 1.0);
  ASSERT_TRUE(mid);
  EXPECT_NEAR((mid->p - Eigen::Vector3d(0.25, 0.0, 0.5)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(mid->q.angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 8, Eigen::Vector3d::UnitZ()))), 0.0,
              1e-12);
  EXPECT_FALSE(interpolatePose(gt, 2.0, 1.5));  // inside the 2 s gap
  EXPECT_TRUE(interpolatePose(gt, 2.0, 2.5));
  EXPECT_FALSE(interpolatePose(gt, -0.1, 10.0));
  EXPECT_FALSE(interpolatePose(gt, 3.1, 10.0));
  ASSERT_TRUE(interpolatePose(gt, 3.0, 0.1));  // exact stamps need no gap check
  EXPECT_DOUBLE_EQ(interpolatePose(gt, 3.0, 0.1)->p.x(), 5.0);

  AssociationOptions options;
  options.interpolate = true;
  options.max_gt_gap_s = 1.5;
  // 0.25 and 0.75 interpolated; 2.0 in the gap (dropped); 3.005 just past the end, within max_dt.
  const auto a = associate(gt, posesAt({0.25, 0.75, 2.0, 3.005, 3.5}), options);
  ASSERT_EQ(a.size(), 3u);
  EXPECT_NEAR(a.gt[1].p.x(), 0.75, 1e-12);
  EXPECT_DOUBLE_EQ(a.gt[1].t, 0.75);
  EXPECT_DOUBLE_EQ(a.est[2].t, 3.005);
  EXPECT_DOUBLE_EQ(a.gt[2].p.x(), 5.0);
}
