// Small examples worked out by hand with evo's definitions, written as the TUM files one would
// pass to `evo_ape tum gt.tum est.tum -a` (SE3 Umeyama) and `-as` (Sim3 Umeyama).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "vims_common/trajectory_io.h"
#include "vims_eval/metrics.h"

using namespace vims::eval;

namespace {

std::string writeFile(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// Ground truth: a 2 m square in the x-y plane, identity orientations.
const char* kGt =
    "# t x y z qx qy qz qw\n"
    "1.00 0 0 0 0 0 0 1\n"
    "2.00 2 0 0 0 0 0 1\n"
    "3.00 2 2 0 0 0 0 1\n"
    "4.00 0 2 0 0 0 0 1\n";

}  // namespace

// EST = R_z(90 deg) * (GT + n) + (10, -5, 3), with n = (0, 0, +-0.1) alternating.
// n has zero mean and is uncorrelated with the centred square (d = (-1,-1), (1,-1), (1,1),
// (-1,1)): sum n_i d_i^T = 0, so Umeyama recovers R_z(-90 deg) and the offset exactly and every
// aligned error is |n_i| = 0.1 m.  evo_ape -a: rmse = mean = median = max = 0.1.
// The stamps are 3 ms off (within evo's default t_max_diff 0.01 s).
// The third pose is additionally yawed by 10 deg: rotation errors (0, 0, 10, 0) deg,
// evo_ape -a -r angle_deg: rmse = sqrt(100 / 4) = 5, mean = 2.5, median = 0, max = 10.
TEST(EvoReference, ApeSe3HandComputed) {
  const double s = std::sqrt(0.5);  // sin(45 deg) = cos(45 deg): quaternion of a 90 deg yaw
  const double s100 = std::sin(100.0 * M_PI / 360.0), c100 = std::cos(100.0 * M_PI / 360.0);  // 100 deg yaw
  char est[1024];
  std::snprintf(est, sizeof(est),
                "1.003 10 -5 3.1 0 0 %.17g %.17g\n"
                "2.003 10 -3 2.9 0 0 %.17g %.17g\n"
                "3.003 8 -3 3.1 0 0 %.17g %.17g\n"
                "4.003 8 -5 2.9 0 0 %.17g %.17g\n",
                s, s, s, s, s100, c100, s, s);
  const auto gt = vims::readTumFile(writeFile("evo_gt.tum", kGt));
  const auto est_poses = vims::readTumFile(writeFile("evo_est_se3.tum", est));

  TrajectoryEvalOptions options;
  options.alignments = {AlignmentMode::kSe3};
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est_poses, options, "est");
  ASSERT_EQ(ev.associated.size(), 4u);
  const AlignedErrors& r = ev.primary();
  EXPECT_NEAR(r.ate.rmse, 0.1, 1e-12);
  EXPECT_NEAR(r.ate.mean, 0.1, 1e-12);
  EXPECT_NEAR(r.ate.median, 0.1, 1e-12);
  EXPECT_NEAR(r.ate.max, 0.1, 1e-12);
  EXPECT_NEAR(r.rot.rmse, 5.0, 1e-9);
  EXPECT_NEAR(r.rot.mean, 2.5, 1e-9);
  EXPECT_NEAR(r.rot.median, 0.0, 1e-9);
  EXPECT_NEAR(r.rot.max, 10.0, 1e-9);
  const Eigen::Matrix3d R_expected = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_NEAR((r.S_w_v.R_w_v - R_expected).norm(), 0.0, 1e-12);
  // p_w = R_z(-90)(p_v - (10, -5, 3)) => t_w_v = -R_z(-90) (10, -5, 3) = (5, 10, -3).
  EXPECT_NEAR((r.S_w_v.t_w_v - Eigen::Vector3d(5, 10, -3)).norm(), 0.0, 1e-12);
  // 6 m of ground-truth path: 0.1 / 6 = 1.6667 %.
  EXPECT_NEAR(ev.gt_distance_m, 6.0, 1e-12);
  EXPECT_NEAR(r.ate_rmse_pct, 100.0 * 0.1 / 6.0, 1e-10);
}

// EST = 2 R_z(90 deg) (GT + n) + (10, -5, 3): the same construction at twice the size.
// Umeyama with scale: sigma_v^2 = 4 (sigma_d^2 + sigma_n^2) = 4 (2 + 0.01), the singular values
// sum to 2 sigma_d^2 = 4, so c = 4 / (4 * 2.01) = 1 / 2.01 = 0.497512... (evo_ape -as prints
// this as the scale correction). The aligned errors are e_i = (2c - 1) d_i + 2c n_i, with d_i
// horizontal and n_i vertical: |e_i|^2 = (0.01/2.01)^2 * 2 + (2/2.01)^2 * 0.01, i.e.
// rmse = 0.1 * sqrt(2 / 2.01) = 0.0997509... for every pose.
TEST(EvoReference, ApeSim3HandComputed) {
  const double s = std::sqrt(0.5);
  char est[1024];
  std::snprintf(est, sizeof(est),
                "1.0 10 -5 3.2 0 0 %.17g %.17g\n"
                "2.0 10 -1 2.8 0 0 %.17g %.17g\n"
                "3.0 6 -1 3.2 0 0 %.17g %.17g\n"
                "4.0 6 -5 2.8 0 0 %.17g %.17g\n",
                s, s, s, s, s, s, s, s);
  const auto gt = vims::readTumFile(writeFile("evo_gt.tum", kGt));
  const auto est_poses = vims::readTumFile(writeFile("evo_est_sim3.tum", est));

  TrajectoryEvalOptions options;
  options.alignments = {AlignmentMode::kSim3, AlignmentMode::kSe3};
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est_poses, options, "est");
  const AlignedErrors& sim3 = *ev.find(AlignmentMode::kSim3);
  EXPECT_NEAR(sim3.S_w_v.scale, 1.0 / 2.01, 1e-12);
  const double expected = 0.1 * std::sqrt(2.0 / 2.01);
  EXPECT_NEAR(sim3.ate.rmse, expected, 1e-12);
  EXPECT_NEAR(sim3.ate.max, expected, 1e-12);
  EXPECT_NEAR(sim3.rot.rmse, 0.0, 1e-9);
  // Without scale, the doubled square cannot fit: every corner is off by |d_i| = sqrt(2) in the
  // plane (the centroids coincide) plus the doubled noise 0.2 vertically.
  const AlignedErrors& se3 = *ev.find(AlignmentMode::kSe3);
  EXPECT_NEAR(se3.ate.rmse, std::sqrt(2.0 + 0.04), 1e-12);
}
