/// Camera-IMU time offset on generated tank sequences whose image stamps lag the exposure by a
/// known delay (vims_sim --camera-delay; fixtures sim_tank_td30 and sim_tank60 in
/// test/CMakeLists.txt), and the sonar-free visual-inertial initialisation wired into the VIO.
///
/// What the tests establish (docs/estimator.md, "Time offset td"): the tracker's matches agree
/// with the ground-truth motion at the simulated delay (the data are right), and the estimator's
/// td model (sign, state time, image velocity, prior) recovers the delay within 3 ms when its
/// observations are the exact projections of the tracked seabed points, and also with the
/// tracker's own observations since the illumination flattening (docs/frontends.md) stopped
/// them drifting along tracks (before it, the estimate was 13 ms short on tank_td30).
///
/// Environment: VIMS_TEST_DATA (set by ctest) holds the sequence folders tank_td30 and tank60.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "sequence_run.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/trajectory_io.h"
#include "vims_estimator/vio_estimator.h"
#include "vims_eval/metrics.h"
#include "vims_ros/sequence_bag_reader.h"
#include "vims_sonar/sonar_altitude_filter.h"
#include "vims_tracking/feature_tracker.h"

namespace {

// The tank's floor is flat: no relief for the sonar factors' misfit growth to allow for
// (SonarDepthOptions::misfit_per_m), so these tests weigh the distant features' sonar factors in
// full, as the paper does. They observe td too: with the default growth (0.3 m/m, for relief)
// the estimate is ~2 ms further off here: +3.1 ms and +33.2 ms with the tracker (README). The
// relief learnt from the sonar's hits (learn_misfit) is 0 on this floor, so misfit_per_m, the
// growth's floor, decides. Each feature is tied to its anchor's own hit, as in the paper, not to
// the window's nearest (tie_to_nearest_hit, docs/factors.md 5g): those ties take the keyframes'
// positions too and move the estimate by ~1 ms here (+3.2 / +33.2 ms with exact features,
// +2.6 / +32.5 ms with the tracker, README).
constexpr double kTankFloorMisfit = 0.0;

/// The paper's sonar depth factors: every feature at full weight on its anchor's hit.
void weighSonarAsThePaper(vims::EstimatorOptions* options) {
  options->factors.sonar_depth.misfit_per_m = kTankFloorMisfit;
  options->factors.sonar_depth.tie_to_nearest_hit = false;
}

using vims::test::ExactProjections;
using vims::test::FrameEdit;
using vims::test::gtPose;
using vims::test::runSequence;
using vims::test::sequenceDir;
using TdRun = vims::test::SequenceRun;

}  // namespace

// Sonar-free mode with the visual-inertial initialisation enabled: on the slow tank motion the
// alignment may not find the scale; whatever it decides, the estimator keeps running, never
// emits a non-finite pose, and a session it starts has a plausible scale (within 20 %: the
// excitation test passed).
TEST(VisualInertialInitOnSequence, Tank60NoSonarIsFiniteAndNeverCrashes) {
  const std::string dir = sequenceDir("tank60");
  if (dir.empty()) GTEST_SKIP() << "VIMS_TEST_DATA is not set (run through ctest with its fixture)";
  vims::EstimatorOptions options;
  options.use_sonar = false;
  options.visual_inertial_init.enabled = true;
  const TdRun run = runSequence(dir, options);
  std::cout << "tank60 no sonar, visual-inertial initialisation: " << run.poses.size() << " poses, resets "
            << run.resets << ", ATE " << run.ate_pct << " %, Sim(3) scale " << run.sim3_scale << "\n";
  EXPECT_TRUE(run.all_finite);
  if (run.poses.size() > 50) {
    EXPECT_NEAR(run.sim3_scale, 1.0, 0.2);
  }
}

namespace {
/// The time shift s (exposure = stamp - s) that makes the tracker's matches between consecutive
/// frames agree best with the ground-truth camera motion (epipolar residual, depth-free): what
/// the images say about the camera delay, independent of the estimator.
double epipolarTimeShift(const std::string& dir) {
  const vims::SequencePaths paths = vims::SequencePaths::resolve(dir);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths.yaml);
  const auto gt = vims::readTumFile(paths.gt);
  vims::FeatureTracker tracker(config.camera, vims::TrackerOptions(), vims::Logger::nullLogger());
  std::vector<vims::TrackedFrame> frames;
  vims::SequenceBagReader reader(paths.bag, config);
  vims::SequenceBagReader::Handlers handlers;
  handlers.image = [&](const vims::CameraFrame& f) { frames.push_back(tracker.process(f)); };
  reader.run(handlers);
  std::vector<double> shifts, costs;
  for (double s = -0.1; s <= 0.1 + 1e-9; s += 0.0025) {
    double cost = 0.0;
    for (std::size_t k = 1; k < frames.size(); ++k) {
      const Eigen::Isometry3d T1 = gtPose(gt, frames[k - 1].t - s) * config.camera.T_b_c;
      const Eigen::Isometry3d T2 = gtPose(gt, frames[k].t - s) * config.camera.T_b_c;
      const Eigen::Isometry3d T12 = T1.inverse() * T2;
      if (T12.translation().norm() < 1e-3) continue;
      const Eigen::Vector3d t = T12.translation().normalized();
      std::map<std::uint64_t, Eigen::Vector2d> prev;
      for (const auto& f : frames[k - 1].features) prev[f.id] = f.normalized;
      for (const auto& f : frames[k].features) {
        auto it = prev.find(f.id);
        if (it == prev.end()) continue;
        const Eigen::Vector3d x1 = it->second.homogeneous();
        const Eigen::Vector3d x2 = f.normalized.homogeneous();
        const double e = x1.dot(t.cross(T12.linear() * x2));
        cost += std::min(e * e, 1e-4);
      }
    }
    shifts.push_back(s);
    costs.push_back(cost);
  }
  const std::size_t best = static_cast<std::size_t>(std::min_element(costs.begin(), costs.end()) - costs.begin());
  if (best == 0 || best + 1 == costs.size()) return shifts[best];
  // Parabola through the minimum and its neighbours.
  const double c0 = costs[best - 1], c1 = costs[best], c2 = costs[best + 1];
  const double denominator = c0 - 2.0 * c1 + c2;
  const double offset = denominator > 0.0 ? std::clamp(0.5 * (c0 - c2) / denominator, -0.5, 0.5) : 0.0;
  return shifts[best] + offset * (shifts[1] - shifts[0]);
}
}  // namespace

// The simulator's --camera-delay and the tracker's stamps: the depth-free epipolar residual of
// consecutive frames' matches against the ground-truth camera motion is smallest at the true
// delay (within 5 ms: the grid is 2.5 ms, refined by a parabola).
TEST(TimeOffset, ImagesAgreeWithGroundTruthAtTheSimulatedDelay) {
  for (const auto& [name, delay] : {std::pair<const char*, double>{"tank60", 0.0}, {"tank_td30", 0.03}}) {
    const std::string dir = sequenceDir(name);
    if (dir.empty()) GTEST_SKIP() << "VIMS_TEST_DATA is not set (run through ctest with its fixture)";
    const double shift = epipolarTimeShift(dir);
    std::cout << name << ": epipolar time shift " << shift << " s (simulated delay " << delay << " s)\n";
    EXPECT_NEAR(shift, delay, 0.005) << name;
  }
}

namespace {
/// Runs the estimator with estimate_td on a sequence whose observations are replaced by the exact
/// projections of the tracked seabed points: each track's point is where its first observation's
/// ray meets the simulator's flat seabed (z = 0, vims_sim/docs/simulator.md) at the ground-truth
/// exposure time t_stamp - delay, and every later observation is that point projected at its own
/// exposure time. The tracks (which features, how long) stay the tracker's. Prints the tracker's
/// error against these projections by track age (its random walk, the cause of the residual td
/// error with real tracking).
double tdWithExactFeatures(const std::string& dir, double delay) {
  ExactProjections exact(dir, delay, true);
  vims::EstimatorOptions options;
  options.estimate_td = true;
  weighSonarAsThePaper(&options);
  const TdRun run = runSequence(dir, options, exact.edit());
  std::cout << "tracker error against the exact projections (rms px) by track age:";
  for (int age : {2, 5, 10, 20, 40}) std::cout << " " << age << ": " << exact.rmsErrorAtAge(age);
  std::cout << "\n";
  EXPECT_TRUE(run.all_finite);
  EXPECT_EQ(run.resets, 0);
  return run.td_final;
}
}  // namespace

// The estimator's td model end to end (t_stamp = t_exposure + td, state time t_stamp - td_frame,
// the state-predicted image velocity, td kept in the marginalisation prior): with exact
// observations along the tracker's tracks it recovers no offset on tank60 and the 30 ms of
// tank_td30, within the 3 ms (measured: +2.2 ms and 32.2 ms). A sign error would give
// -30 ms and a velocity per frame instead of per second ten times the offset; without td in the
// prior the estimate wanders by +-15 ms on the same data.
TEST(TimeOffset, EstimatorRecoversTheDelayFromExactFeatures) {
  for (const auto& [name, delay] : {std::pair<const char*, double>{"tank60", 0.0}, {"tank_td30", 0.03}}) {
    const std::string dir = sequenceDir(name);
    if (dir.empty()) GTEST_SKIP() << "VIMS_TEST_DATA is not set (run through ctest with its fixture)";
    const double td = tdWithExactFeatures(dir, delay);
    std::cout << name << ": estimated td " << td << " s with exact features (simulated delay " << delay << " s)\n";
    EXPECT_NEAR(td, delay, 0.003) << name;
  }
}

// The acceptance test: the whole VIO as vims_offline runs it (tracker included), with
// estimate_td, recovers no offset on tank60 and the 30 ms of tank_td30 within 3 ms (measured
// +1.4 ms and +31.5 ms). A tracker whose error accumulates along tracks gave +16.7 ms on
// tank_td30 (KLT on the CLAHE image instead of the flattened one), a sign error about -30 ms.
TEST(TimeOffset, EstimatorRecoversTheDelayWithTheTrackersFeatures) {
  for (const auto& [name, delay] : {std::pair<const char*, double>{"tank60", 0.0}, {"tank_td30", 0.03}}) {
    const std::string dir = sequenceDir(name);
    if (dir.empty()) GTEST_SKIP() << "VIMS_TEST_DATA is not set (run through ctest with its fixture)";
    vims::EstimatorOptions options;
    options.estimate_td = true;
    weighSonarAsThePaper(&options);
    const TdRun run = runSequence(dir, options);
    std::cout << name << ": estimated td " << run.td_final << " s with the tracker (simulated delay " << delay
              << " s), VIO ATE " << run.ate_pct << " %\n";
    EXPECT_TRUE(run.all_finite);
    EXPECT_EQ(run.resets, 0);
    EXPECT_NEAR(run.td_final, delay, 0.003) << name;
    EXPECT_LT(run.ate_pct, 0.1) << name;
  }
}
