#include "sequence_run.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "vims_common/sequence_paths.h"
#include "vims_estimator/vio_estimator.h"
#include "vims_eval/metrics.h"
#include "vims_ros/sequence_bag_reader.h"
#include "vims_sonar/sonar_altitude_filter.h"
#include "vims_tracking/feature_tracker.h"

namespace vims {
namespace test {

SequenceRun runSequence(const std::string& dir, const EstimatorOptions& options, const FrameEdit& edit) {
  const vims::SequencePaths paths = vims::SequencePaths::resolve(dir);
  const vims::SequenceConfig config = vims::SequenceConfig::load(paths.yaml);
  auto logger = vims::Logger::stderrLogger(vims::LogLevel::kError);
  vims::SonarAltitudeFilter sonar_filter(vims::SonarFilterOptions(), config.sonar, logger);
  vims::FeatureTracker tracker(config.camera, vims::TrackerOptions(), logger);
  vims::VioEstimator vio(config, options, logger);
  SequenceRun run;
  auto drain = [&] {
    for (const vims::VioFrameResult& r : vio.takeFrameResults()) {
      if (r.status == vims::VioStatus::kReset) ++run.resets;
      if (r.status == vims::VioStatus::kReset || r.status == vims::VioStatus::kWaitingForImu) continue;
      if (!r.T_odom_b_at_stamp.matrix().allFinite() || !std::isfinite(r.td)) run.all_finite = false;
      vims::StampedPose p;
      // The state's own time t_stamp - td_estimate: the exposure time on the IMU (ground-truth)
      // clock when td is right, so a wrong td also shows in the ATE.
      p.t = r.t_state;
      p.p = r.T_odom_b.translation();
      p.q = Eigen::Quaterniond(r.T_odom_b.linear());
      run.poses.push_back(p);
    }
    vio.takeKeyframes();
  };
  std::vector<vims::SonarFilterResult> sonar_results;
  vims::SequenceBagReader reader(paths.bag, config);
  vims::SequenceBagReader::Handlers handlers;
  handlers.imu = [&](const vims::ImuSample& s) {
    vio.feedImu(s);
    drain();
  };
  handlers.image = [&](const vims::CameraFrame& f) {
    vims::TrackedFrame tracked = tracker.process(f);
    if (edit) edit(&tracked);
    vio.feedFrame(tracked, f.image);
    drain();
  };
  handlers.sonar = [&](const vims::SonarRange& r) {
    sonar_results.clear();
    sonar_filter.feed(r, &sonar_results);
    for (const auto& result : sonar_results) vio.feedSonar(result);
  };
  reader.run(handlers);
  drain();
  run.td_final = vio.td();

  vims::eval::TrajectoryEvalOptions eval_options;
  eval_options.alignments = {vims::eval::AlignmentMode::kSe3, vims::eval::AlignmentMode::kSim3};
  if (run.poses.size() > 50) {
    const auto evaluation = vims::eval::evaluateTrajectory(vims::readTumFile(paths.gt), run.poses, eval_options, "vio");
    run.ate_pct = evaluation.find(vims::eval::AlignmentMode::kSe3)->ate_rmse_pct;
    run.sim3_scale = evaluation.find(vims::eval::AlignmentMode::kSim3)->S_w_v.scale;
  }
  return run;
}

std::string sequenceDir(const std::string& name) {
  const char* root = std::getenv("VIMS_TEST_DATA");
  if (!root || !*root) return "";
  return (std::filesystem::path(root) / name).string();
}

Eigen::Isometry3d gtPose(const std::vector<vims::StampedPose>& gt, double t) {
  auto it = std::lower_bound(gt.begin(), gt.end(), t, [](const vims::StampedPose& p, double v) { return p.t < v; });
  if (it == gt.begin()) it = gt.begin() + 1;
  if (it == gt.end()) it = gt.end() - 1;
  const vims::StampedPose& a = *(it - 1);
  const vims::StampedPose& b = *it;
  const double w = std::clamp((t - a.t) / (b.t - a.t), 0.0, 1.0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = a.q.slerp(w, b.q).toRotationMatrix();
  T.translation() = (1.0 - w) * a.p + w * b.p;
  return T;
}

ExactProjections::ExactProjections(const std::string& dir, double delay, bool replace)
    : config_(SequenceConfig::load(SequencePaths::resolve(dir).yaml)),
      camera_(config_.camera),
      gt_(readTumFile(SequencePaths::resolve(dir).gt)),
      delay_(delay),
      replace_(replace) {}

void ExactProjections::operator()(TrackedFrame* frame) {
  const Eigen::Isometry3d T_w_c = gtPose(gt_, frame->t - delay_) * config_.camera.T_b_c;
  const Eigen::Vector2d principal(camera_.cx(), camera_.cy());
  for (TrackedFeature& f : frame->features) {
    auto it = seabed_points_.find(f.id);
    if (it == seabed_points_.end()) {
      const Eigen::Vector3d ray = T_w_c.linear() * f.normalized.homogeneous();
      if (!(ray.z() < 0.0)) continue;
      it = seabed_points_.emplace(f.id, T_w_c.translation() - T_w_c.translation().z() / ray.z() * ray).first;
    }
    const Eigen::Vector3d p_c = T_w_c.inverse() * it->second;
    const Eigen::Vector2d projection = p_c.head<2>() / p_c.z();
    auto& [sum, count] = error_by_age_[std::min(f.track_length, 40)];
    sum += (config_.camera.fx * (f.normalized - projection)).squaredNorm();
    ++count;
    if (f.track_length >= kMinRadialAge) {
      const Eigen::Vector2d exact_px = camera_.pixelFromNormalized(projection);
      const Eigen::Vector2d from_centre = exact_px - principal;
      const double r = from_centre.norm();
      if (r >= 1.0) {
        const Eigen::Vector2d e = camera_.pixelFromNormalized(f.normalized) - exact_px;
        auto& bin = radial_[static_cast<int>(r / kRadialBinPx)];
        bin[0] += e.dot(from_centre / r);
        bin[1] += e.squaredNorm();
        bin[2] += 1.0;
      }
    }
    if (replace_) f.normalized = projection;
  }
}

double ExactProjections::rmsErrorAtAge(int age) const {
  const auto it = error_by_age_.find(age);
  if (it == error_by_age_.end() || it->second.second == 0) return NAN;
  return std::sqrt(it->second.first / it->second.second);
}

std::vector<ExactProjections::RadialBin> ExactProjections::radialErrors() const {
  std::vector<RadialBin> out;
  for (const auto& [k, sums] : radial_) {
    RadialBin b;
    b.r0_px = k * kRadialBinPx;
    b.r1_px = (k + 1) * kRadialBinPx;
    b.mean_radial_px = sums[0] / sums[2];
    b.rms_px = std::sqrt(sums[1] / sums[2]);
    b.count = static_cast<int>(sums[2]);
    out.push_back(b);
  }
  return out;
}

}  // namespace test
}  // namespace vims
