#pragma once
/// @file manager_test_runs.h
/// @brief The rendered runs the PoseGraphManager tests share (test_pose_graph_manager.cpp,
/// test_teach_and_repeat.cpp): one synthetic seabed with a coil, two runs over it on other paths
/// with drifting VIO, the options and feeding of the manager, and comparisons with the truth.
/// The runs are rendered once per test binary.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "loop_test_world.h"
#include "vims_pose_graph/pose_graph_manager.h"

namespace vims {
namespace manager_test {

using test::bodyPose;
using test::kDeg;

constexpr uint64_t kWorldSeed = 777;

inline sim::CoilDipole testCoil() {
  sim::CoilDipole coil;
  coil.position_w = Eigen::Vector3d(3.0, 0.3, 0.0);
  return coil;
}

/// The geomagnetic field of the site in ENU (declination 0).
inline const Eigen::Vector3d kGeomagneticEnu(0.0, 2.2e-5, -4.1e-5);

/// A run: the true body poses, the VIO's keyframes (drifting, in its own frame), and the
/// magnetometer outputs along the way.
struct SimRun {
  std::vector<Eigen::Isometry3d> T_w_b;
  std::vector<KeyframeData> keyframes;
  std::vector<SignatureWindow> signatures;
  std::vector<std::pair<double, Eigen::Vector3d>> geomagnetic;  ///< (t, field in body)
};

/// Lawnmower pass A: east along y = 0, turn, west along y = 0.6 (heading 180: the revisits see
/// the seabed rotated by 180 deg).
inline std::vector<Eigen::Isometry3d> trajectoryA() {
  std::vector<Eigen::Isometry3d> p;
  for (int i = 0; i < 16; ++i) p.push_back(bodyPose(0.4 * i, 0.0, 2.5 + 0.1 * std::sin(0.5 * i), 0.0, 1.0, -0.5));
  p.push_back(bodyPose(6.2, 0.25, 2.5, 90.0));
  for (int i = 0; i < 16; ++i)
    p.push_back(bodyPose(5.8 - 0.4 * i, 0.6, 2.6 + 0.1 * std::cos(0.4 * i), 180.0, -0.8, 1.0));
  return p;
}

/// SimRun B over the same area on another path: diagonally north-east, then back west.
inline std::vector<Eigen::Isometry3d> trajectoryB() {
  std::vector<Eigen::Isometry3d> p;
  for (int i = 0; i < 13; ++i) p.push_back(bodyPose(0.5 + 0.38 * i, -0.4 + 0.13 * i, 2.7, 19.0, 0.5, 0.5));
  for (int i = 0; i < 12; ++i) p.push_back(bodyPose(5.2 - 0.4 * i, 1.0 - 0.05 * i, 2.6, 185.0, -0.5, 0.0));
  return p;
}

/// Builds a run: keyframes `dt` apart; the VIO frame is `T_odom_w` and the VIO drifts by
/// yaw_drift_deg_per_m and a scale error; signatures every 0.4 s and geomagnetic samples every
/// 0.1 s from the true poses (interpolated).
inline SimRun makeRun(const test::TestWorld& world, const std::vector<Eigen::Isometry3d>& poses, double dt,
                      const Eigen::Isometry3d& T_odom_w, double yaw_drift_deg_per_m, double scale, double t0 = 100.0) {
  SimRun run;
  run.T_w_b = poses;
  Eigen::Isometry3d T_odom_b = T_odom_w * poses.front();
  for (size_t i = 0; i < poses.size(); ++i) {
    if (i > 0) {
      // The VIO integrates the true relative motion with a scale error and a yaw drift.
      Eigen::Isometry3d rel = poses[i - 1].inverse() * poses[i];
      const double d = rel.translation().norm();
      rel.translation() *= scale;
      rel.linear() = rotationZ(yaw_drift_deg_per_m * kDeg * d) * rel.linear();
      T_odom_b = T_odom_b * rel;
    }
    run.keyframes.push_back(world.keyframe(t0 + dt * i, 0, poses[i], T_odom_b));
  }
  const sim::CoilDipole coil = testCoil();
  const double t_end = t0 + dt * (poses.size() - 1);
  auto poseAt = [&](double t) {
    const double f = std::clamp((t - t0) / dt, 0.0, static_cast<double>(poses.size() - 1));
    const size_t i = std::min(static_cast<size_t>(f), poses.size() - 2);
    const double a = f - i;
    Eigen::Isometry3d T = poses[a < 0.5 ? i : i + 1];
    T.translation() = (1 - a) * poses[i].translation() + a * poses[i + 1].translation();
    return T;
  };
  for (double t = t0; t <= t_end + 1e-9; t += 0.4)
    run.signatures.push_back(test::signatureAt(t, coil, poseAt(t).translation()));
  for (double t = t0; t <= t_end + 1e-9; t += 0.1)
    run.geomagnetic.emplace_back(t, poseAt(t).linear().transpose() * kGeomagneticEnu);
  return run;
}

/// Runs rendered once per test binary.
inline const SimRun& runA() {
  static const SimRun run = makeRun(test::TestWorld(kWorldSeed), trajectoryA(), 1.0,
                                    test::yawTransform(35.0, Eigen::Vector3d(2.0, -1.0, 0.0)), 0.6, 1.02);
  return run;
}
inline const SimRun& runB() {
  static const SimRun run = makeRun(test::TestWorld(kWorldSeed), trajectoryB(), 1.0,
                                    test::yawTransform(-70.0, Eigen::Vector3d(10.0, 5.0, 0.2)), -0.4, 0.99, 5000.0);
  return run;
}

inline PoseGraphManagerOptions testOptions(LoopClosingMode mode = LoopClosingMode::kFull) {
  PoseGraphManagerOptions o;
  o.mode = mode;
  o.synchronous = true;
  o.optimise_every_n_keyframes = 5;
  // Short test runs: keyframes 1 s apart.
  o.loop.exclude_recent_keyframes = 10;
  o.loop.exclude_recent_s = 8.0;
  return o;
}

inline std::shared_ptr<const BinaryVocabulary> vocabularyFor(const PoseGraphManagerOptions& o) {
  return test::vocabulary(o.modeSettings().descriptor == DescriptorType::kOrb ? "orb_k8l4.vocab" : "brief_k8l4.vocab");
}

struct FeedOptions {
  double mag_off_from = 1e300;  ///< no signatures at or after this time
  bool geomagnetic = true;
};

/// Feeds a run in time order (keyframes, signatures and geomagnetic samples interleaved).
inline void feed(PoseGraphManager& m, const SimRun& run, const FeedOptions& f = FeedOptions()) {
  size_t s = 0, g = 0;
  for (const KeyframeData& kf : run.keyframes) {
    for (; s < run.signatures.size() && run.signatures[s].t <= kf.t; ++s)
      if (run.signatures[s].t < f.mag_off_from) m.feedSignature(run.signatures[s]);
    for (; g < run.geomagnetic.size() && run.geomagnetic[g].first <= kf.t; ++g)
      if (f.geomagnetic) m.feedGeomagnetic(run.geomagnetic[g].first, run.geomagnetic[g].second);
    m.feedKeyframe(kf);
  }
  for (; s < run.signatures.size(); ++s)
    if (run.signatures[s].t < f.mag_off_from) m.feedSignature(run.signatures[s]);
  for (; g < run.geomagnetic.size(); ++g)
    if (f.geomagnetic) m.feedGeomagnetic(run.geomagnetic[g].first, run.geomagnetic[g].second);
  m.finish();
}

/// Truth of a keyframe time.
inline Eigen::Isometry3d truthAt(const SimRun& run, double t) {
  for (size_t i = 0; i < run.keyframes.size(); ++i)
    if (std::abs(run.keyframes[i].t - t) < 1e-6) return run.T_w_b[i];
  ADD_FAILURE() << "no keyframe at t=" << t;
  return Eigen::Isometry3d::Identity();
}

/// Max position error of a run's keyframe poses expressed in a frame G, given T_G_w.
inline double maxPositionError(const std::vector<KeyframePose>& poses, const SimRun& run,
                               const Eigen::Isometry3d& T_G_w) {
  double worst = 0.0;
  for (const KeyframePose& k : poses)
    worst = std::max(worst, (k.T_w_b.translation() - (T_G_w * truthAt(run, k.t)).translation()).norm());
  return worst;
}

/// The frame of a run's global poses relative to the world, from its first keyframe.
inline Eigen::Isometry3d frameOf(const std::vector<KeyframePose>& poses, const SimRun& run) {
  return poses.front().T_w_b * truthAt(run, poses.front().t).inverse();
}

/// Accepted loops agree with the truth in what the 4-DoF graph uses: the relative position and
/// the relative yaw (the PnP tilt is dropped; it is checked in 6-DoF in test_loop_verification).
inline void expectAcceptedLoopsCorrect(const std::vector<LoopAttempt>& attempts, const SimRun& query_run,
                                       const SimRun& match_run, double max_translation_error_m = 0.1) {
  for (const LoopAttempt& a : attempts) {
    if (!a.accepted) continue;
    const Eigen::Isometry3d gt = truthAt(match_run, a.t_match).inverse() * truthAt(query_run, a.t_query);
    const Eigen::Matrix3d dR = a.T_match_query.linear().transpose() * gt.linear();
    EXPECT_LT((a.T_match_query.translation() - gt.translation()).norm(), max_translation_error_m)
        << "loop " << a.t_query << " -> " << a.t_match;
    EXPECT_LT(std::abs(yawPitchRollFromRotation(dR).yaw) / kDeg, 1.0) << "loop " << a.t_query << " -> " << a.t_match;
    EXPECT_LT(Eigen::AngleAxisd(dR).angle() / kDeg, 3.0) << "loop " << a.t_query << " -> " << a.t_match;
  }
}

inline std::string tempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("vims_pgm_" + std::to_string(::getpid()) + "_" + name)).string();
}

}  // namespace manager_test
}  // namespace vims
