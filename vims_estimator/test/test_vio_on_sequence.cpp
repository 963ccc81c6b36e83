/// System tests of VioEstimator on simulated sequences (CTest fixtures sim_tank60 / sim_tank30,
/// folder in VIMS_TEST_DATA): the whole odometry in-process (bag reader -> sonar filter ->
/// tracker -> estimator), its accuracy against ground truth, the sonar's role for scale, and the
/// rules for bad input (NaN and gaps in the IMU, camera blackout, sonar outage, time going
/// backwards).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <functional>
#include <iostream>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_common/trajectory_io.h"
#include "vims_estimator/vio_estimator.h"
#include "vims_eval/metrics.h"
#include "vims_ros/sequence_bag_reader.h"
#include "vims_sonar/sonar_altitude_filter.h"
#include "vims_tracking/feature_tracker.h"

namespace {

std::string sequenceDir(const std::string& name) {
  const char* root = std::getenv("VIMS_TEST_DATA");
  if (!root || !*root) return "";
  return (std::filesystem::path(root) / name).string();
}

/// Hooks that edit or drop messages on their way into the pipeline (return false: drop).
struct Perturbation {
  std::function<bool(vims::ImuSample&)> imu;
  std::function<bool(vims::CameraFrame&)> image;
  std::function<bool(vims::SonarRange&)> sonar;
  /// [s] The filtered ranges reach the estimator only once the IMU is this far past their stamp
  /// (on the AUV they come one node hop after the image of the same time).
  double sonar_delay_s = 0.0;
};

struct RunResult {
  std::vector<vims::StampedPose> poses;  ///< body pose at every frame stamp (what vio.tum holds)
  std::vector<vims::VioFrameResult> results;
  int resets = 0;             ///< frames reporting a reset (failure detection)
  long estimator_resets = 0;  ///< every dropped session, also those an IMU input triggered
  std::uint32_t last_session = 0;
  bool all_finite = true;
  double td = 0.0;
  std::size_t keyframes = 0;
  std::size_t keyframe_features = 0;
  std::optional<vims::VioImuState> imu_state;  ///< IMU-propagated state at the end
  /// Reprojection error [px] of every keyframe feature's p_odom into its keyframe.
  std::vector<double> keyframe_reprojection_px;
};

/// Runs bag -> sonar filter -> tracker -> VioEstimator, like vims_offline does.
RunResult runVio(const std::string& dir, const vims::EstimatorOptions& options, const Perturbation& perturbation = {},
                 const std::function<void(vims::SequenceConfig&)>& edit_estimator_calibration = {}) {
  const vims::SequencePaths paths = vims::SequencePaths::resolve(dir);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths.yaml);
  vims::SequenceConfig estimator_config = config;
  if (edit_estimator_calibration) edit_estimator_calibration(estimator_config);
  auto logger = vims::Logger::stderrLogger(vims::LogLevel::kError);
  vims::SonarAltitudeFilter sonar_filter(vims::SonarFilterOptions(), config.sonar, logger);
  vims::FeatureTracker tracker(config.camera, vims::TrackerOptions(), logger);
  vims::VioEstimator vio(estimator_config, options, logger);
  RunResult run;
  auto drain = [&] {
    for (const vims::VioFrameResult& r : vio.takeFrameResults()) {
      run.results.push_back(r);
      if (r.status == vims::VioStatus::kReset) ++run.resets;
      if (r.status == vims::VioStatus::kReset || r.status == vims::VioStatus::kWaitingForImu) continue;
      const Eigen::Isometry3d& T = r.T_odom_b_at_stamp;
      if (!T.matrix().allFinite() || !r.v_odom_b.allFinite()) run.all_finite = false;
      vims::StampedPose p;
      p.t = r.t_stamp;
      p.p = T.translation();
      p.q = Eigen::Quaterniond(T.linear());
      run.poses.push_back(p);
      run.last_session = r.session;
    }
    for (const vims::KeyframeData& kf : vio.takeKeyframes()) {
      ++run.keyframes;
      const Eigen::Isometry3d T_c_odom = (kf.T_odom_b * estimator_config.camera.T_b_c).inverse();
      for (const vims::KeyframeLandmark& f : kf.features) {
        ++run.keyframe_features;
        const Eigen::Vector3d p_c = T_c_odom * f.p_odom;
        const double err = p_c.z() > 0 ? (p_c.head<2>() / p_c.z() - f.normalized).norm() * config.camera.fx : 1e9;
        run.keyframe_reprojection_px.push_back(err);
      }
    }
  };
  std::vector<vims::SonarFilterResult> sonar_results;
  std::deque<vims::SonarFilterResult> delayed_sonar;
  vims::SequenceBagReader reader(paths.bag, config);
  vims::SequenceBagReader::Handlers handlers;
  handlers.imu = [&](const vims::ImuSample& s) {
    vims::ImuSample sample = s;
    if (perturbation.imu && !perturbation.imu(sample)) return;
    while (!delayed_sonar.empty() && delayed_sonar.front().t + perturbation.sonar_delay_s <= sample.t) {
      vio.feedSonar(delayed_sonar.front());
      delayed_sonar.pop_front();
      drain();
    }
    vio.feedImu(sample);
    drain();
  };
  handlers.image = [&](const vims::CameraFrame& f) {
    vims::CameraFrame frame = f;
    if (perturbation.image && !perturbation.image(frame)) return;
    vio.feedFrame(tracker.process(frame), frame.image);
    drain();
  };
  handlers.sonar = [&](const vims::SonarRange& r) {
    vims::SonarRange range = r;
    if (perturbation.sonar && !perturbation.sonar(range)) return;
    sonar_results.clear();
    sonar_filter.feed(range, &sonar_results);
    for (const auto& result : sonar_results) {
      if (perturbation.sonar_delay_s > 0.0) {
        delayed_sonar.push_back(result);
      } else {
        vio.feedSonar(result);
        drain();
      }
    }
  };
  reader.run(handlers);
  drain();
  run.td = vio.td();
  run.imu_state = vio.imuPropagatedState();
  run.estimator_resets = vio.resets();
  return run;
}

struct Accuracy {
  double ate_se3_pct = 0.0;
  double ate_se3_m = 0.0;
  double rot_rmse_deg = 0.0;  ///< after position-yaw alignment (roll and pitch are observable)
  double sim3_scale = 1.0;
};

Accuracy evaluate(const std::string& dir, const std::vector<vims::StampedPose>& est) {
  const vims::SequencePaths paths = vims::SequencePaths::resolve(dir);
  const auto gt = vims::readTumFile(paths.gt);
  vims::eval::TrajectoryEvalOptions options;
  options.alignments = {vims::eval::AlignmentMode::kSe3, vims::eval::AlignmentMode::kSim3,
                        vims::eval::AlignmentMode::kPosYaw};
  const auto evaluation = vims::eval::evaluateTrajectory(gt, est, options, "vio");
  Accuracy a;
  a.ate_se3_pct = evaluation.find(vims::eval::AlignmentMode::kSe3)->ate_rmse_pct;
  a.ate_se3_m = evaluation.find(vims::eval::AlignmentMode::kSe3)->ate.rmse;
  a.rot_rmse_deg = evaluation.find(vims::eval::AlignmentMode::kPosYaw)->rot.rmse;
  a.sim3_scale = evaluation.find(vims::eval::AlignmentMode::kSim3)->S_w_v.scale;
  return a;
}

#define REQUIRE_SEQUENCE(dir, name)          \
  const std::string dir = sequenceDir(name); \
  if (dir.empty()) GTEST_SKIP() << "VIMS_TEST_DATA is not set (run through ctest with its fixture)"

}  // namespace

// The full system on tank60 (60 s, 3 s static start, ~10 m travelled): measured ATE 0.040 % of
// the distance and 0.118 deg rotation error (SE3 alignment, commit 3d8bce4). The bounds are about
// twice that; a broken factor or a wrong extrinsic exceeds them (next test).
constexpr double kAteBoundPct = 0.08;
constexpr double kRotBoundDeg = 0.25;
// tank30 with bad input, about twice what each case measures: NaN IMU samples and a 0.2 s gap
// (ATE 0.290 %), a 2 s camera blackout (0.209 %).
constexpr double kImuGlitchAteBoundPct = 0.58;
constexpr double kBlackoutAteBoundPct = 0.42;

TEST(VioOnSequence, Tank60AccuracyWithinBounds) {
  REQUIRE_SEQUENCE(dir, "tank60");
  const RunResult run = runVio(dir, vims::EstimatorOptions());
  ASSERT_GT(run.poses.size(), 550u) << "a pose for (almost) every one of the 600 frames";
  EXPECT_TRUE(run.all_finite);
  EXPECT_EQ(run.resets, 0);
  EXPECT_GT(run.keyframes, 20u);
  // The IMU-rate state reaches the last IMU sample and stays next to the last frame's pose.
  ASSERT_TRUE(run.imu_state.has_value());
  EXPECT_TRUE(run.imu_state->T_odom_b.matrix().allFinite());
  EXPECT_GE(run.imu_state->t, run.poses.back().t);
  EXPECT_LT((run.imu_state->T_odom_b.translation() - run.poses.back().p).norm(), 0.05);
  // KeyframeData for the pose graph: features with 3D points that agree with their observation.
  ASSERT_GT(run.keyframe_features, 20u * run.keyframes);
  std::vector<double> err = run.keyframe_reprojection_px;
  std::nth_element(err.begin(), err.begin() + err.size() / 2, err.end());
  EXPECT_LT(err[err.size() / 2], 1.5) << "median reprojection of keyframe features [px]";
  // Initialised at the first frame with enough IMU (static start): no frame of the moving part is lost.
  EXPECT_LT(run.poses.front().t - run.results.front().t_stamp, 1.0);
  const Accuracy a = evaluate(dir, run.poses);
  std::cout << "tank60 full: ATE " << a.ate_se3_m << " m (" << a.ate_se3_pct << " %), rot " << a.rot_rmse_deg
            << " deg, sim3 scale " << a.sim3_scale << "\n";
  EXPECT_LT(a.ate_se3_pct, kAteBoundPct);
  EXPECT_LT(a.rot_rmse_deg, kRotBoundDeg);
}

TEST(VioOnSequence, RangesArrivingAfterTheirImageGiveTheSameOdometry) {
  // On the AUV the filtered range of time t reaches the estimator after the image of time t (one
  // node hop); offline it comes first. Frames wait for it (sonar_wait_s), so both orders give
  // the same odometry; without the wait a frame took the previous range when its own was late.
  REQUIRE_SEQUENCE(dir, "tank60");
  const RunResult in_order = runVio(dir, vims::EstimatorOptions());
  Perturbation late;
  late.sonar_delay_s = 0.03;  // 6 IMU samples: later than the image, well within the wait
  const RunResult delayed = runVio(dir, vims::EstimatorOptions(), late);
  ASSERT_EQ(delayed.poses.size(), in_order.poses.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < in_order.poses.size(); ++i) {
    ASSERT_EQ(delayed.poses[i].t, in_order.poses[i].t);
    worst = std::max(worst, (delayed.poses[i].p - in_order.poses[i].p).norm());
  }
  EXPECT_EQ(worst, 0.0) << "late ranges changed the odometry by up to " << worst << " m";

  vims::EstimatorOptions no_wait;
  no_wait.sonar_wait_s = 0.0;
  const RunResult stale = runVio(dir, no_wait, late);
  double stale_worst = 0.0;
  for (std::size_t i = 0; i < std::min(stale.poses.size(), in_order.poses.size()); ++i)
    stale_worst = std::max(stale_worst, (stale.poses[i].p - in_order.poses[i].p).norm());
  EXPECT_GT(stale_worst, 1e-6) << "without the wait, late ranges should have changed the odometry";
}

TEST(VioOnSequence, WrongCameraExtrinsicExceedsTheBound) {
  REQUIRE_SEQUENCE(dir, "tank60");
  // The estimator is given a camera extrinsic rotated by 3 deg about the body x axis and shifted
  // by 5 cm: a typical hand-measured calibration error. With the paper's seabed (level, every
  // feature's sonar factor at full weight) the error shows; the defaults take the camera's 3 deg
  // for a sloping seabed (local plane) and weigh distant features less (misfit_per_m), and stay
  // within the bounds (measured: 0.040 %, 0.24 deg with the local plane; 0.049 %, 0.25 deg with
  // the level seabed and the misfit growth), so they are not the model that can show that the
  // bounds are tight.
  vims::EstimatorOptions level;
  level.seabed.model = vims::SeabedModel::kHorizontal;
  level.factors.sonar_depth.misfit_per_m = 0.0;
  level.factors.sonar_depth.learn_misfit = false;
  const RunResult run = runVio(dir, level, {}, [](vims::SequenceConfig& c) {
    Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
    delta.linear() = Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
    delta.translation() = Eigen::Vector3d(0.05, 0.0, 0.0);
    c.camera.T_b_c = delta * c.camera.T_b_c;
  });
  ASSERT_GT(run.poses.size(), 100u);
  const Accuracy a = evaluate(dir, run.poses);
  std::cout << "tank60 wrong T_b_c: ATE " << a.ate_se3_m << " m (" << a.ate_se3_pct << " %), rot " << a.rot_rmse_deg
            << " deg\n";
  EXPECT_TRUE(a.ate_se3_pct > kAteBoundPct || a.rot_rmse_deg > kRotBoundDeg);
}

TEST(VioOnSequence, SonarFixesTheScale) {
  REQUIRE_SEQUENCE(dir, "tank60");
  const Accuracy with_sonar = evaluate(dir, runVio(dir, vims::EstimatorOptions()).poses);
  vims::EstimatorOptions no_sonar;
  no_sonar.use_sonar = false;
  const RunResult run = runVio(dir, no_sonar);
  ASSERT_GT(run.poses.size(), 100u);
  const Accuracy without = evaluate(dir, run.poses);
  std::cout << "tank60 sim3 scale: with sonar " << with_sonar.sim3_scale << ", without " << without.sim3_scale
            << " (ATE " << without.ate_se3_pct << " %)\n";
  // Measured: 1.004 with the sonar; without it the low-excitation motion leaves the scale
  // essentially undetermined (0.84 with the default 4 solver iterations, 0.20 with 8).
  EXPECT_LT(std::abs(with_sonar.sim3_scale - 1.0), 0.02);
  EXPECT_GT(std::abs(without.sim3_scale - 1.0), 5.0 * std::abs(with_sonar.sim3_scale - 1.0));
}

// ---- bad input (tank30: 30 s, 3 s static start) ----

TEST(VioBadInput, NanAndShortGapInImuKeepTracking) {
  REQUIRE_SEQUENCE(dir, "tank30");
  double first_t = std::numeric_limits<double>::quiet_NaN();
  Perturbation p;
  p.imu = [&](vims::ImuSample& s) {
    if (std::isnan(first_t)) first_t = s.t;
    const double rel = s.t - first_t;
    if (rel > 10.0 && rel < 10.5) s.accel.x() = std::numeric_limits<double>::quiet_NaN();  // NaN samples
    if (rel > 15.0 && rel < 15.2) return false;  // 0.2 s gap (< imu_max_gap_s): integrated across
    return true;
  };
  const RunResult run = runVio(dir, vims::EstimatorOptions(), p);
  EXPECT_TRUE(run.all_finite);
  EXPECT_EQ(run.resets, 0);
  EXPECT_GT(run.poses.size(), 250u);
  const Accuracy a = evaluate(dir, run.poses);
  std::cout << "tank30 with NaN IMU samples and a 0.2 s gap: ATE " << a.ate_se3_pct << " %\n";
  EXPECT_LT(a.ate_se3_pct, kImuGlitchAteBoundPct);
}

TEST(VioBadInput, LongImuGapResetsAndStartsANewSession) {
  REQUIRE_SEQUENCE(dir, "tank30");
  double first_t = std::numeric_limits<double>::quiet_NaN();
  Perturbation p;
  p.imu = [&](vims::ImuSample& s) {
    if (std::isnan(first_t)) first_t = s.t;
    const double rel = s.t - first_t;
    return !(rel > 12.0 && rel < 14.0);  // 2 s without IMU
  };
  const RunResult run = runVio(dir, vims::EstimatorOptions(), p);
  EXPECT_TRUE(run.all_finite);
  EXPECT_GE(run.last_session, 1u) << "the gap reset the estimator and a new session started";
  EXPECT_EQ(run.estimator_resets, 1) << "one reset, counted although no frame reported it";
  // Frames after the gap get poses again.
  ASSERT_FALSE(run.poses.empty());
  EXPECT_GT(run.poses.back().t - first_t, 28.0);
}

TEST(VioBadInput, CameraBlackoutPropagatesAndRecovers) {
  REQUIRE_SEQUENCE(dir, "tank30");
  double first_t = std::numeric_limits<double>::quiet_NaN();
  Perturbation p;
  p.imu = [&](vims::ImuSample& s) {
    if (std::isnan(first_t)) first_t = s.t;
    return true;
  };
  p.image = [&](vims::CameraFrame& f) {
    const double rel = f.t - first_t;
    if (rel > 12.0 && rel < 14.0) f.image.setTo(0);  // 2 s lamp failure: blank frames
    return true;
  };
  const RunResult run = runVio(dir, vims::EstimatorOptions(), p);
  EXPECT_TRUE(run.all_finite);
  int no_visual = 0;
  for (const auto& r : run.results) no_visual += r.status == vims::VioStatus::kNoVisualUpdate;
  EXPECT_GT(no_visual, 10) << "blank frames are propagated with the IMU";
  EXPECT_EQ(run.resets, 0) << "2 s is shorter than failure_lost_tracking_s";
  const Accuracy a = evaluate(dir, run.poses);
  std::cout << "tank30 with a 2 s blackout: ATE " << a.ate_se3_pct << " %\n";
  EXPECT_LT(a.ate_se3_pct, kBlackoutAteBoundPct);
}

TEST(VioBadInput, SonarOutageFallsBackToVisualInertial) {
  REQUIRE_SEQUENCE(dir, "tank30");
  double first_t = std::numeric_limits<double>::quiet_NaN();
  Perturbation p;
  p.imu = [&](vims::ImuSample& s) {
    if (std::isnan(first_t)) first_t = s.t;
    return true;
  };
  p.sonar = [&](vims::SonarRange& r) {
    return !(r.t - first_t > 0.0 && r.t - first_t < 30.0);
  };  // sonar off throughout
  const RunResult run = runVio(dir, vims::EstimatorOptions(), p);
  EXPECT_TRUE(run.all_finite);
  EXPECT_GT(run.poses.size(), 250u);
  int sonar_factors = 0;
  for (const auto& r : run.results) sonar_factors += r.sonar_factors;
  EXPECT_EQ(sonar_factors, 0);
}

TEST(VioBadInput, TimeGoingBackwardsResets) {
  REQUIRE_SEQUENCE(dir, "tank30");
  // Replays the stream with every stamp after 15 s moved 5 s into the past (a bag loop / clock
  // jump): IMU, images and sonar all jump back together.
  double first_t = std::numeric_limits<double>::quiet_NaN();
  auto shift = [&](double t) {
    if (std::isnan(first_t)) first_t = t;
    return t - first_t > 15.0 ? t - 5.0 : t;
  };
  Perturbation p;
  p.imu = [&](vims::ImuSample& s) {
    s.t = shift(s.t);
    return true;
  };
  p.image = [&](vims::CameraFrame& f) {
    f.t = shift(f.t);
    return true;
  };
  p.sonar = [&](vims::SonarRange& r) {
    r.t = shift(r.t);
    return true;
  };
  const RunResult run = runVio(dir, vims::EstimatorOptions(), p);
  EXPECT_TRUE(run.all_finite);
  EXPECT_GE(run.last_session, 1u) << "the clock jump reset the estimator";
  ASSERT_FALSE(run.poses.empty());
}
