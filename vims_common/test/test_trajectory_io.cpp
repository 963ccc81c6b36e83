#include <gtest/gtest.h>

#include <fstream>

#include "vims_common/trajectory_io.h"

TEST(TrajectoryIo, WriteReadRoundTrip) {
  const std::string path = ::testing::TempDir() + "/vims_traj.tum";
  std::vector<vims::StampedPose> poses(3);
  for (int i = 0; i < 3; ++i) {
    poses[i].t = 1700000000.0 + 0.1 * i;
    poses[i].p = Eigen::Vector3d(i, -2.0 * i, 0.5);
    poses[i].q = Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d::UnitZ()));
  }
  vims::writeTumFile(path, poses);
  const auto back = vims::readTumFile(path);
  ASSERT_EQ(back.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(back[i].t, poses[i].t, 1e-6);
    EXPECT_NEAR((back[i].p - poses[i].p).norm(), 0.0, 1e-6);
    EXPECT_NEAR(back[i].q.angularDistance(poses[i].q), 0.0, 1e-8);
  }
}

TEST(TrajectoryIo, RejectsMalformedLinesWithLineNumber) {
  const std::string path = ::testing::TempDir() + "/vims_bad.tum";
  {
    std::ofstream out(path);
    out << "# comment\n0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n";
  }
  try {
    vims::readTumFile(path);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(":3:"), std::string::npos) << e.what();
  }
  {
    std::ofstream out(path);
    out << "1 0 0 0 0 0 0 1\n0.5 0 0 0 0 0 0 1\n";
  }
  EXPECT_THROW(vims::readTumFile(path), std::runtime_error);
  EXPECT_THROW(vims::readTumFile("/nonexistent.tum"), std::runtime_error);
}
