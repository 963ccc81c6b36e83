#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/geomagnetic_gate.h"

using namespace vims;

namespace {

constexpr double kDeg = M_PI / 180.0;

/// A field of `total` [T] pointing `inclination_deg` below the horizon, `declination_deg` east of north.
Eigen::Vector3d fieldEnu(double total, double inclination_deg, double declination_deg) {
  const double h = total * std::cos(inclination_deg * kDeg);
  return Eigen::Vector3d(h * std::sin(declination_deg * kDeg), h * std::cos(declination_deg * kDeg),
                         -total * std::sin(inclination_deg * kDeg));
}

/// The candidate of field `B_w` measured by a body with this attitude.
GeomagneticCandidate measured(uint32_t node, const Eigen::Vector3d& B_w, double yaw, double pitch, double roll) {
  // The VIO's odometry frame is the world turned by 30 deg about the vertical.
  const Eigen::Matrix3d R_odom_b = rotationFromYawPitchRoll(yaw - 30.0 * kDeg, pitch, roll);
  const Eigen::Vector3d B_b = rotationFromYawPitchRoll(yaw, pitch, roll).transpose() * B_w;
  return GeomagneticGate::levelled(node, 0, 0.5 * node, B_b, R_odom_b);
}

}  // namespace

TEST(GeomagneticGate, LevellingRecoversTheMagnitudeAndInclinationAtAnyAttitude) {
  const Eigen::Vector3d B_w = fieldEnu(49e-6, 46.0, 4.0);
  for (double yaw : {-2.0, 0.3, 3.0})
    for (double pitch : {-0.2, 0.0, 0.15})
      for (double roll : {-0.1, 0.05}) {
        const GeomagneticCandidate c = measured(7, B_w, yaw, pitch, roll);
        EXPECT_NEAR(c.magnitude_tesla, 49e-6, 1e-15);
        EXPECT_NEAR(c.inclination_rad, 46.0 * kDeg, 1e-12);
        EXPECT_EQ(c.node, 7u);
      }
  // The azimuth is the field's horizontal direction in the odometry frame (its yaws are 30 deg less).
  const double world_azimuth = std::atan2(B_w.y(), B_w.x());
  EXPECT_NEAR(wrapAngle(measured(0, B_w, 1.0, 0.1, -0.05).azimuth_odom_rad - (world_azimuth - 30.0 * kDeg)), 0.0,
              1e-12);
  // The southern hemisphere: the field points up, the inclination is negative.
  EXPECT_NEAR(measured(0, fieldEnu(30e-6, -40.0, 0.0), 1.0, 0.1, 0.0).inclination_rad, -40.0 * kDeg, 1e-12);
}

TEST(GeomagneticGate, HoldsUntilTheSiteIsKnownThenJudgesInOrder) {
  GeomagneticGateOptions options;
  options.min_samples = 5;
  GeomagneticGate gate(options);
  const Eigen::Vector3d B_w = fieldEnu(49e-6, 46.0, 4.0);
  for (uint32_t k = 0; k < 4; ++k) EXPECT_TRUE(gate.add(measured(k, B_w, 0.1 * k, 0.0, 0.0)).empty());
  const std::vector<GeomagneticVerdict> first = gate.add(measured(4, B_w, 0.4, 0.0, 0.0));
  ASSERT_EQ(first.size(), 5u);
  for (uint32_t k = 0; k < 5; ++k) {
    EXPECT_EQ(first[k].candidate.node, k);
    EXPECT_TRUE(first[k].accepted);
  }
  const std::vector<GeomagneticVerdict> next = gate.add(measured(5, B_w, 0.5, 0.0, 0.0));
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(next[0].candidate.node, 5u);
  EXPECT_TRUE(gate.flush().empty());
  EXPECT_EQ(gate.numJudged(), 6u);
}

TEST(GeomagneticGate, RejectsADisturbedMinorityAndKeepsTheCleanField) {
  GeomagneticGateOptions options;  // defaults: 1.5 %, 0.75 deg, 0.5 deg
  GeomagneticGate gate(options);
  std::mt19937 rng(3);
  std::normal_distribution<double> magnitude_noise(0.0, 0.002), inclination_noise(0.0, 0.05);
  const double total = 49e-6, inclination = 46.0;
  std::vector<bool> disturbed;
  std::vector<GeomagneticVerdict> verdicts;
  for (uint32_t k = 0; k < 100; ++k) {
    // Every fourth sample near steel: 2.5 % stronger, or 1.5 deg steeper, or both.
    const bool bent = k % 4 == 3;
    const uint32_t kind = (k / 4) % 3;  // 0: magnitude, 1: inclination, 2: both
    const double dm = bent && kind != 1 ? 0.025 : 0.0;
    const double di = bent && kind != 0 ? 1.5 : 0.0;
    disturbed.push_back(bent);
    const Eigen::Vector3d B_w =
        fieldEnu(total * (1.0 + dm + magnitude_noise(rng)), inclination + di + inclination_noise(rng), 4.0);
    for (const GeomagneticVerdict& v : gate.add(measured(k, B_w, 0.07 * k, 0.02, -0.03))) verdicts.push_back(v);
  }
  ASSERT_EQ(verdicts.size(), 100u);
  for (const GeomagneticVerdict& v : verdicts)
    EXPECT_EQ(v.accepted, !disturbed[v.candidate.node])
        << "node " << v.candidate.node << ": magnitude " << v.magnitude_error_fraction << ", inclination "
        << v.inclination_error_rad / kDeg << " deg";
  EXPECT_EQ(gate.numRejected(), 25u);
  // The medians stay on the clean site's values despite a quarter of disturbed samples.
  EXPECT_NEAR(gate.siteMagnitude() / total, 1.0, 0.002);
  EXPECT_NEAR(gate.siteInclination() / kDeg, inclination, 0.05);
}

TEST(GeomagneticGate, DisabledAcceptsEverythingButStillEstimatesTheSite) {
  GeomagneticGateOptions options;
  options.enabled = false;
  options.min_samples = 3;
  GeomagneticGate gate(options);
  size_t accepted = 0;
  for (uint32_t k = 0; k < 10; ++k) {
    const std::vector<GeomagneticVerdict> verdicts =
        gate.add(measured(k, fieldEnu(49e-6 * (k == 5 ? 1.1 : 1.0), 46.0, 0.0), 0, 0, 0));
    ASSERT_EQ(verdicts.size(), 1u);  // no warm-up: nothing is held
    accepted += verdicts[0].accepted ? 1 : 0;
  }
  EXPECT_EQ(accepted, 10u);
  EXPECT_EQ(gate.numRejected(), 0u);
  EXPECT_NEAR(gate.siteMagnitude(), 49e-6, 1e-15);
}

TEST(GeomagneticGate, AShortRunIsJudgedAtTheEndOrAcceptedWhenTooShortToKnowTheSite) {
  GeomagneticGateOptions options;  // min_samples 20
  const Eigen::Vector3d clean = fieldEnu(49e-6, 46.0, 0.0), strong = fieldEnu(52e-6, 46.0, 0.0);
  GeomagneticGate two(options);
  EXPECT_TRUE(two.add(measured(0, clean, 0, 0, 0)).empty());
  EXPECT_TRUE(two.add(measured(1, strong, 0, 0, 0)).empty());
  const std::vector<GeomagneticVerdict> too_few = two.flush();
  ASSERT_EQ(too_few.size(), 2u);
  EXPECT_TRUE(too_few[0].accepted && too_few[1].accepted);

  GeomagneticGate four(options);
  for (uint32_t k = 0; k < 3; ++k) EXPECT_TRUE(four.add(measured(k, clean, 0.2 * k, 0, 0)).empty());
  EXPECT_TRUE(four.add(measured(3, strong, 0, 0, 0)).empty());
  const std::vector<GeomagneticVerdict> judged = four.flush();
  ASSERT_EQ(judged.size(), 4u);
  EXPECT_TRUE(judged[0].accepted && judged[1].accepted && judged[2].accepted);
  EXPECT_FALSE(judged[3].accepted);
  EXPECT_NEAR(judged[3].magnitude_error_fraction, 3.0 / 49.0, 1e-12);
}

TEST(GeomagneticGate, RejectsAFieldBentAcrossTheHorizontalAndFollowsTheVioDrift) {
  for (double drift_over_run_deg : {60.0, 1.0}) {
    GeomagneticGate gate{GeomagneticGateOptions{}};  // heading 0.5 deg in a 120 s window
    std::vector<GeomagneticVerdict> verdicts;
    for (uint32_t k = 0; k < 600; ++k) {
      const double t = 0.5 * k;
      // The VIO's yaw drifts by 60 deg over the 300 s (a failing gyro bias, 0.2 deg/s: modelled as
      // a line), or by 1 deg (twice what VIMS's VIO drifts: the constant reference); the field is
      // the site's except for t in [100, 130), where steel turns it by 1.5 deg about the vertical
      // (same magnitude and inclination: invisible to the invariants).
      const double bend_deg = t >= 100.0 && t < 130.0 ? 1.5 : 0.0;
      const double drift_deg = drift_over_run_deg * t / 300.0;
      const Eigen::Vector3d B_w = fieldEnu(49e-6, 46.0, 4.0 + bend_deg);
      const double yaw = 0.01 * k, pitch = 0.03, roll = -0.02;
      const Eigen::Matrix3d R_odom_b = rotationFromYawPitchRoll(yaw + drift_deg * kDeg, pitch, roll);
      const Eigen::Vector3d B_b = rotationFromYawPitchRoll(yaw, pitch, roll).transpose() * B_w;
      for (const GeomagneticVerdict& v : gate.add(GeomagneticGate::levelled(k, k < 400 ? 0 : 1, t, B_b, R_odom_b)))
        verdicts.push_back(v);
    }
    for (const GeomagneticVerdict& v : gate.flush()) verdicts.push_back(v);
    ASSERT_EQ(verdicts.size(), 600u);
    for (const GeomagneticVerdict& v : verdicts) {
      const bool bent = v.candidate.t >= 100.0 && v.candidate.t < 130.0;
      EXPECT_EQ(v.accepted, !bent) << "t=" << v.candidate.t << ": azimuth off by " << v.heading_error_rad / kDeg;
      EXPECT_NEAR(v.magnitude_error_fraction, 0.0, 1e-12);
    }
    EXPECT_EQ(gate.numRejected(), 60u) << drift_over_run_deg << " deg of drift";
  }
}

TEST(GeomagneticGate, ANewVioSessionStartsItsOwnHeadingReference) {
  GeomagneticGate gate{GeomagneticGateOptions{}};
  const Eigen::Vector3d B_w = fieldEnu(49e-6, 46.0, 4.0);
  size_t accepted = 0;
  for (uint32_t k = 0; k < 100; ++k) {
    // After a VIO reset (session 1) the odometry frame is turned by 90 deg: the azimuths jump.
    const uint32_t session = k < 50 ? 0 : 1;
    const Eigen::Matrix3d R_odom_b = rotationFromYawPitchRoll(0.02 * k + (session == 1 ? M_PI / 2 : 0.0), 0, 0);
    const Eigen::Vector3d B_b = rotationFromYawPitchRoll(0.02 * k, 0, 0).transpose() * B_w;
    for (const GeomagneticVerdict& v : gate.add(GeomagneticGate::levelled(k, session, 0.5 * k, B_b, R_odom_b)))
      accepted += v.accepted ? 1 : 0;
  }
  EXPECT_EQ(accepted, 100u);
}

TEST(GeomagneticGate, ARestartedSiteJudgesByTheRemeasuredSamples) {
  // 60 samples measured 4 % too strong (the vehicle's own field, not yet known), then the same
  // samples re-measured: after the restart the site is the re-measured one and a clean sample
  // passes where, judged against the old medians, it was rejected.
  GeomagneticGate gate(GeomagneticGateOptions{});
  const Eigen::Vector3d clean = fieldEnu(49e-6, 46.0, 4.0);
  std::vector<GeomagneticCandidate> remeasured;
  for (uint32_t k = 0; k < 60; ++k) {
    gate.add(measured(k, clean * 1.04, 0.05 * k, 0.0, 0.0));
    remeasured.push_back(measured(k, clean, 0.05 * k, 0.0, 0.0));
  }
  std::vector<GeomagneticVerdict> before = gate.add(measured(60, clean, 3.0, 0.0, 0.0));
  ASSERT_EQ(before.size(), 1u);
  EXPECT_FALSE(before[0].accepted);
  EXPECT_NEAR(before[0].magnitude_error_fraction, 1.0 / 1.04 - 1.0, 1e-9);
  remeasured.push_back(measured(60, clean, 3.0, 0.0, 0.0));
  gate.restartSite(remeasured);
  EXPECT_NEAR(gate.siteMagnitude(), 49e-6, 1e-15);
  const std::vector<GeomagneticVerdict> after = gate.add(measured(61, clean, 3.05, 0.0, 0.0));
  ASSERT_EQ(after.size(), 1u);
  EXPECT_TRUE(after[0].accepted);
  EXPECT_NEAR(after[0].magnitude_error_fraction, 0.0, 1e-9);
  // The counts are the run's: 62 judged, the one rejection kept.
  EXPECT_EQ(gate.numJudged(), 62u);
  EXPECT_EQ(gate.numRejected(), 1u);
}
