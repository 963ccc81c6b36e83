#include "vims_estimator/vio_estimator.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "vims_estimator/factors/imu_factor.h"
#include "vims_estimator/factors/marginalization_factor.h"
#include "vims_estimator/factors/pose_prior_factor.h"
#include "vims_estimator/factors/reprojection_factor.h"
#include "vims_estimator/factors/sonar_depth_factor.h"
#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

namespace {

constexpr const char* kComponent = "vio";

/// The gauge prior on a session's first keyframe pins the arbitrary origin and yaw of the VIO
/// frame (measurements cannot inform them). 1 mm / 1 mrad is far below anything the window can
/// resolve, so it fixes the gauge without competing with any measurement.
constexpr double kGaugeSigmaPosition = 1e-3;
constexpr double kGaugeSigmaYaw = 1e-3;
/// A feature must lie at least this far in front of a target camera for its reprojection factor
/// to be added (the projection is undefined at z = 0 and badly conditioned just in front of it).
constexpr double kMinTargetDepth = 0.05;
/// A ray must point at least this much downwards (z component of the unit ray in the gravity
/// aligned frame) to be intersected with the seabed plane: grazing rays give unbounded depths.
constexpr double kMinRayDownComponent = 0.1;

/// Linear prior on a speed-bias block: r = diag(1/sigma) (x - x0).
class SpeedBiasPriorFactor : public ceres::SizedCostFunction<9, 9> {
 public:
  SpeedBiasPriorFactor(const Eigen::Matrix<double, 9, 1>& x0, const Eigen::Matrix<double, 9, 1>& inv_sigma)
      : x0_(x0), inv_sigma_(inv_sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    Eigen::Map<const Eigen::Matrix<double, 9, 1>> x(parameters[0]);
    Eigen::Map<Eigen::Matrix<double, 9, 1>> r(residuals);
    r = inv_sigma_.cwiseProduct(x - x0_);
    if (jacobians && jacobians[0]) {
      Eigen::Map<Eigen::Matrix<double, 9, 9, Eigen::RowMajor>> J(jacobians[0]);
      J.setZero();
      J.diagonal() = inv_sigma_;
    }
    return true;
  }

 private:
  Eigen::Matrix<double, 9, 1> x0_;
  Eigen::Matrix<double, 9, 1> inv_sigma_;
};

/// Rotation with the given gravity-aligned roll/pitch and zero yaw that maps the body-frame
/// specific force at rest (pointing up) onto +z of the VIO frame.
Eigen::Quaterniond gravityAlignedAttitude(const Eigen::Vector3d& accel_b) {
  Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(accel_b.normalized(), Eigen::Vector3d::UnitZ());
  const Eigen::Matrix3d R = q.toRotationMatrix();
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  q = Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()) * q;
  return q.normalized();
}

bool finiteState(const double* pose, const double* sb) {
  for (int i = 0; i < kPoseSize; ++i) {
    if (!std::isfinite(pose[i])) return false;
  }
  for (int i = 0; i < kSpeedBiasSize; ++i) {
    if (!std::isfinite(sb[i])) return false;
  }
  return true;
}

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

const char* vioStatusName(VioStatus status) {
  switch (status) {
    case VioStatus::kWaitingForImu: return "waiting_for_imu";
    case VioStatus::kInitialized: return "initialized";
    case VioStatus::kTracking: return "tracking";
    case VioStatus::kNoVisualUpdate: return "no_visual_update";
    case VioStatus::kReset: return "reset";
  }
  return "unknown";
}

// ---------------------------------------------------------------------------------------------
// Window content
// ---------------------------------------------------------------------------------------------

struct VioEstimator::Frame {
  struct Obs {
    FeatureObservation fo;
    Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  };
  double t_stamp = 0.0;
  double t_state = 0.0;
  /// Raw gyroscope reading at t_state (the image velocity prediction subtracts the bias).
  Eigen::Vector3d gyro_at_state = Eigen::Vector3d::Zero();
  double pose[kPoseSize] = {0, 0, 0, 0, 0, 0, 1};
  double sb[kSpeedBiasSize] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  /// Preintegration from the previous window frame to this one (null for the oldest frame).
  std::shared_ptr<ImuPreintegration> preintegration;
  std::map<std::uint64_t, Obs> obs;
  std::optional<double> sonar_range;
  /// The session's first frame carries the gauge and first-state priors until marginalised.
  bool has_first_state_prior = false;
  Eigen::Vector3d prior_p = Eigen::Vector3d::Zero();
  Eigen::Quaterniond prior_q = Eigen::Quaterniond::Identity();
  Eigen::Matrix<double, 9, 1> prior_sb = Eigen::Matrix<double, 9, 1>::Zero();
  bool keyframe_emitted = false;
  cv::Mat image;

  Eigen::Isometry3d T_l_b() const { return poseBlockToIsometry(pose); }
};

struct VioEstimator::Feature {
  std::uint64_t id = 0;
  Frame* anchor = nullptr;
  double lambda[1] = {0.0};
  bool has_depth = false;
  bool sonar_ok = true;  ///< false once the flat-bottom gate flagged the feature (rock, wall)
};

namespace {
/// One residual block of the window, built identically for the solve and for marginalisation.
struct ResidualSpec {
  ceres::CostFunction* cost = nullptr;  ///< owned by whoever consumes the spec
  bool sonar = false;                   ///< Cauchy (sonar) or Huber (reprojection) loss
  std::vector<double*> blocks;
};

/// Solver settings of the window solves: a few dogleg iterations from the previous solution,
/// single-threaded (the offline runner's determinism), with the optional wall-clock cap.
ceres::Solver::Options windowSolverOptions(const EstimatorOptions& options, ceres::LinearSolverType linear_solver) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = linear_solver;
  solver_options.trust_region_strategy_type = ceres::DOGLEG;
  solver_options.max_num_iterations = options.max_solver_iterations;
  if (options.max_solver_time_s > 0.0) solver_options.max_solver_time_in_seconds = options.max_solver_time_s;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  return solver_options;
}
}  // namespace

// ---------------------------------------------------------------------------------------------
// Construction and input
// ---------------------------------------------------------------------------------------------

VioEstimator::VioEstimator(const SequenceConfig& sequence, const EstimatorOptions& options, LoggerPtr logger)
    : sequence_(sequence), options_(options), logger_(std::move(logger)) {
  noise_ = ImuNoiseParams::fromCalibration(sequence_.imu);
  g_l_ = Eigen::Vector3d(0.0, 0.0, -sequence_.imu.gravity);
  focal_ = 0.5 * (sequence_.camera.fx + sequence_.camera.fy);
  if (!(focal_ > 0.0)) throw std::invalid_argument("VioEstimator: camera focal length must be > 0");
  sonar_sigma_ = options_.factors.sonar_depth.sigma(
      std::max(sequence_.sonar.range_noise_std, options_.sonar_min_range_std_m));
  isometryToPoseBlock(sequence_.camera.T_b_c, T_b_c_block_);
  td_[0] = options_.td_initial_s;
}

VioEstimator::~VioEstimator() = default;

Eigen::Isometry3d VioEstimator::extrinsicCamera() const { return poseBlockToIsometry(T_b_c_block_); }

void VioEstimator::reset(const std::string& why) {
  if (!frames_.empty()) {
    logger_->warn(kComponent, "reset: " + why + " (a new session starts at the next frame)");
    ++resets_;
  }
  frames_.clear();
  features_.clear();
  priors_.clear();
  vi_init_frames_.clear();
  seabed_fix_.reset();  // a new session has a new frame l
}

void VioEstimator::feedImu(const ImuSample& sample) {
  if (!std::isfinite(sample.t) || !sample.gyro.allFinite() || !sample.accel.allFinite()) {
    logger_->warnThrottled(kComponent, "imu_nan", imu_.empty() ? 0.0 : imu_.back().t, 5.0,
                           "dropping a non-finite IMU sample");
    return;
  }
  if (!imu_.empty()) {
    const double dt = sample.t - imu_.back().t;
    if (dt == 0.0) {
      logger_->warnThrottled(kComponent, "imu_dup", sample.t, 5.0, "dropping an IMU sample with a repeated stamp");
      return;
    }
    if (dt < 0.0) {
      logger_->warn(kComponent, VIMS_STR("IMU time went backwards by " << -dt << " s: resetting"));
      reset("IMU time went backwards");
      imu_.clear();
      pending_.clear();
      sonar_.clear();
      last_frame_stamp_ = -std::numeric_limits<double>::infinity();
    } else if (dt > options_.imu_max_gap_s) {
      logger_->warn(kComponent, VIMS_STR("IMU gap of " << dt << " s (> imu_max_gap_s): resetting"));
      reset("IMU gap");
      imu_.clear();
    }
  }
  imu_.push_back(sample);
  processPendingFrames();
  // Before initialisation (and while frames are missing) nothing else prunes the buffer.
  if (imu_.size() % 1024 == 0) pruneImu();
}

void VioEstimator::feedSonar(const SonarFilterResult& result) {
  if (!result.accepted || !result.has_estimate || !std::isfinite(result.filtered) || !(result.filtered > 0.0)) return;
  if (!sonar_.empty() && result.t <= sonar_.back().first) {
    if (result.t < sonar_.back().first) sonar_.clear();  // clock went backwards: old ranges are void
    else return;
  }
  sonar_.emplace_back(result.t, result.filtered);
  processPendingFrames();  // a frame may have been waiting for this range
}

void VioEstimator::feedFrame(const TrackedFrame& frame, const cv::Mat& image) {
  if (!frame.accepted() || !std::isfinite(frame.t)) return;
  if (frame.t <= last_frame_stamp_) {
    logger_->warn(kComponent, VIMS_STR("image stamp " << frame.t << " not after the previous " << last_frame_stamp_
                                                      << ": resetting"));
    reset("image time went backwards");
    pending_.clear();
  }
  last_frame_stamp_ = frame.t;
  pending_.emplace_back(frame, image);
  processPendingFrames();
}

std::vector<VioFrameResult> VioEstimator::takeFrameResults() {
  std::vector<VioFrameResult> out;
  out.swap(results_);
  return out;
}

std::vector<KeyframeData> VioEstimator::takeKeyframes() {
  std::vector<KeyframeData> out;
  out.swap(keyframes_);
  return out;
}

std::optional<VioImuState> VioEstimator::imuPropagatedState() const {
  if (frames_.empty() || imu_.empty()) return std::nullopt;
  const Frame& f = *frames_.back();
  VioImuState s;
  s.session = session_;
  Eigen::Vector3d p = posePosition(f.pose);
  Eigen::Quaterniond q(poseRotation(f.pose));
  Eigen::Vector3d v = sbVelocity(f.sb);
  const Eigen::Vector3d ba = sbAccelBias(f.sb), bg = sbGyroBias(f.sb);
  double t = f.t_state;
  // Mid-point propagation through the buffered samples after the newest frame.
  auto it = std::upper_bound(imu_.begin(), imu_.end(), t, [](double value, const ImuSample& x) { return value < x.t; });
  if (it != imu_.begin()) {
    ImuSample prev = *(it - 1);
    for (; it != imu_.end(); ++it) {
      const double dt = it->t - t;
      const Eigen::Vector3d w = 0.5 * (prev.gyro + it->gyro) - bg;
      const Eigen::Quaterniond q1 = (q * so3::exp(w * dt)).normalized();
      const Eigen::Vector3d a = 0.5 * (q * (prev.accel - ba) + q1 * (it->accel - ba)) + g_l_;
      p += v * dt + 0.5 * a * dt * dt;
      v += a * dt;
      q = q1;
      t = it->t;
      prev = *it;
    }
  }
  s.t = t;
  s.T_odom_b.linear() = q.toRotationMatrix();
  s.T_odom_b.translation() = p;
  s.v_odom_b = v;
  return s;
}

// ---------------------------------------------------------------------------------------------
// Frame processing
// ---------------------------------------------------------------------------------------------

void VioEstimator::processPendingFrames() {
  while (!pending_.empty() && !imu_.empty()) {
    // A frame the IMU will not reach (IMU stopped, or images far ahead) is dropped rather than
    // holding every later frame back.
    if (pending_.size() > 1 && pending_.back().first.t - pending_.front().first.t > options_.max_frame_wait_s) {
      logger_->warnThrottled(kComponent, "frame_wait", pending_.front().first.t, 5.0,
                             "dropping a frame the IMU does not cover");
      pending_.pop_front();
      continue;
    }
    const double t_stamp = pending_.front().first.t;
    const double t_needed = std::max(t_stamp, t_stamp - td_[0]);
    if (imu_.back().t < t_needed) return;
    // The range at the frame's time may still be on its way (online it comes a node hop after
    // the image): wait for a range at or after the frame, or for the IMU to be sonar_wait_s past it.
    if (options_.use_sonar && options_.sonar_wait_s > 0.0 && (sonar_.empty() || sonar_.back().first < t_needed) &&
        imu_.back().t < t_needed + options_.sonar_wait_s)
      return;
    auto [frame, image] = std::move(pending_.front());
    pending_.pop_front();
    processFrame(frame, image);
  }
}

std::optional<double> VioEstimator::sonarRangeAt(double t) const {
  if (sonar_.empty()) return std::nullopt;
  const double gap = options_.sonar_max_interpolation_gap_s;
  auto it = std::lower_bound(sonar_.begin(), sonar_.end(), t,
                             [](const std::pair<double, double>& s, double value) { return s.first < value; });
  if (it != sonar_.end() && it != sonar_.begin()) {
    const auto& a = *(it - 1);
    const auto& b = *it;
    if (t - a.first <= gap && b.first - t <= gap) {
      const double w = (t - a.first) / (b.first - a.first);
      return a.second + w * (b.second - a.second);
    }
  }
  // No bracketing pair (the newest range is older than the frame): hold the nearest range if it
  // is within half the interpolation gap.
  double best_dt = std::numeric_limits<double>::infinity();
  double best = 0.0;
  if (it != sonar_.end()) {
    best_dt = it->first - t;
    best = it->second;
  }
  if (it != sonar_.begin() && t - (it - 1)->first < best_dt) {
    best_dt = t - (it - 1)->first;
    best = (it - 1)->second;
  }
  if (best_dt <= 0.5 * gap) return best;
  return std::nullopt;
}

std::unique_ptr<VioEstimator::Frame> VioEstimator::makeFrame(const TrackedFrame& tracked, const cv::Mat& image,
                                                             double t_state) {
  auto frame = std::make_unique<Frame>();
  frame->t_stamp = tracked.t;
  frame->t_state = t_state;
  frame->gyro_at_state = gyroAt(t_state);
  frame->image = image;
  if (options_.use_sonar) frame->sonar_range = sonarRangeAt(t_state);
  return frame;
}

void VioEstimator::addObservations(Frame* frame, const TrackedFrame& tracked) {
  for (const TrackedFeature& tf : tracked.features) {
    if (!tf.normalized.allFinite() || !tf.normalized_velocity.allFinite() || !tf.pixel.allFinite()) continue;
    Frame::Obs obs;
    obs.fo.uv = tf.normalized;
    // fo.velocity is predicted from the state before every solve (predictImageVelocities), not
    // taken from the tracker: see there.
    obs.fo.td_frame = frame->t_stamp - frame->t_state;
    obs.pixel = tf.pixel;
    frame->obs[tf.id] = obs;
    auto it = features_.find(tf.id);
    if (it == features_.end()) {
      Feature f;
      f.id = tf.id;
      f.anchor = frame;
      features_.emplace(tf.id, f);
    }
  }
}

bool VioEstimator::initializeFirstFrame(const TrackedFrame& tracked, const cv::Mat& image, double t_state) {
  if (static_cast<int>(tracked.features.size()) < std::max(1, options_.failure_min_tracked)) return false;
  if (imu_.empty() || imu_.front().t > t_state - 0.5 * options_.init_gravity_window_s) return false;
  // Gravity from the accelerometer average over the last init_gravity_window_s before the frame.
  Eigen::Vector3d acc_sum = Eigen::Vector3d::Zero(), gyr_sum = Eigen::Vector3d::Zero();
  std::vector<const ImuSample*> used;
  for (const ImuSample& s : imu_) {
    if (s.t > t_state) break;
    if (s.t >= t_state - options_.init_gravity_window_s) used.push_back(&s);
  }
  if (used.size() < 10) return false;
  for (const ImuSample* s : used) {
    acc_sum += s->accel;
    gyr_sum += s->gyro;
  }
  const double n = static_cast<double>(used.size());
  const Eigen::Vector3d acc_mean = acc_sum / n, gyr_mean = gyr_sum / n;
  double acc_var = 0.0, gyr_var = 0.0;
  for (const ImuSample* s : used) {
    acc_var += std::pow(s->accel.norm() - acc_mean.norm(), 2);
    gyr_var += (s->gyro - gyr_mean).squaredNorm();
  }
  const bool is_static = std::sqrt(acc_var / n) < options_.init_static_accel_std &&
                         std::sqrt(gyr_var / n) < options_.init_static_gyro_std;
  if (acc_mean.norm() < 0.5 * sequence_.imu.gravity) return false;  // free fall or garbage: no gravity

  auto frame = makeFrame(tracked, image, t_state);
  const Eigen::Quaterniond q = gravityAlignedAttitude(acc_mean);
  setPose(frame->pose, Eigen::Vector3d::Zero(), q);
  Eigen::Map<Eigen::Matrix<double, 9, 1>> sb(frame->sb);
  sb.setZero();
  if (is_static) sb.segment<3>(6) = gyr_mean;  // at rest the gyro mean is its bias
  frame->has_first_state_prior = true;
  frame->prior_p = Eigen::Vector3d::Zero();
  frame->prior_q = q;
  frame->prior_sb = sb;
  addObservations(frame.get(), tracked);
  frames_.push_back(std::move(frame));
  session_ = session_started_ ? session_ + 1 : 0;
  session_started_ = true;
  last_good_tracking_t_ = tracked.t;
  initializeFeatureDepths();
  logger_->info(kComponent, VIMS_STR("session " << session_ << " initialised at t=" << std::fixed << std::setprecision(3) << tracked.t
                                                << (is_static ? " (static start)" : " (moving start: v0 = 0 assumed)")
                                                << ", " << tracked.features.size() << " features, sonar "
                                                << (frames_.back()->sonar_range ? "available" : "not available")));
  return true;
}

bool VioEstimator::initializeVisualInertial(const TrackedFrame& tracked, const cv::Mat& image, double t_state) {
  const VisualInertialInitOptions& init = options_.visual_inertial_init;
  if (static_cast<int>(tracked.features.size()) < std::max(1, options_.failure_min_tracked)) {
    vi_init_frames_.clear();  // the scene is lost: start the window again
    return false;
  }
  // Candidate frames: a frame joins when it moved by keyframe_parallax_px from the newest
  // candidate; if it shares too few features with it the window restarts from this frame.
  if (!vi_init_frames_.empty()) {
    const TrackedFrame& last = vi_init_frames_.back().frame;
    std::map<std::uint64_t, Eigen::Vector2d> last_uv;
    for (const TrackedFeature& f : last.features) last_uv[f.id] = f.normalized;
    double parallax = 0.0;
    int common = 0;
    for (const TrackedFeature& f : tracked.features) {
      auto it = last_uv.find(f.id);
      if (it == last_uv.end()) continue;
      parallax += (f.normalized - it->second).norm();
      ++common;
    }
    if (t_state <= vi_init_frames_.back().t_state) {
      vi_init_frames_.clear();
    } else if (common < init.min_relative_pose_features) {
      vi_init_frames_.clear();
    } else if (focal_ * parallax / common < options_.keyframe_parallax_px) {
      return false;  // too close to the newest candidate
    }
  }
  vi_init_frames_.push_back({tracked, image, t_state});
  if (static_cast<int>(vi_init_frames_.size()) < init.window_frames) return false;

  std::vector<InitFrame> window;
  for (std::size_t k = 0; k < vi_init_frames_.size(); ++k) {
    InitFrame f;
    f.t = vi_init_frames_[k].t_state;
    for (const TrackedFeature& tf : vi_init_frames_[k].frame.features) {
      if (tf.normalized.allFinite()) f.observations[tf.id] = tf.normalized;
    }
    if (k > 0) {
      const auto samples = imuSamplesForInterval(imu_, vi_init_frames_[k - 1].t_state, f.t);
      if (!samples || samples->size() < 2) {
        logger_->warnThrottled(kComponent, "vi_init_imu", tracked.t, 5.0,
                               "visual-inertial initialisation: the IMU does not cover the window; restarting it");
        vi_init_frames_.clear();
        return false;
      }
      f.preintegration = std::make_shared<ImuPreintegration>(
          ImuPreintegration::fromSamples(*samples, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), noise_));
    }
    window.push_back(std::move(f));
  }
  const VisualInertialInitializer initializer(sequence_.camera.T_b_c, sequence_.imu.gravity, focal_, init);
  const VisualInertialInitResult r = initializer.initialize(window);
  if (!r.ok()) {
    logger_->warnThrottled(kComponent, "vi_init", tracked.t, 5.0,
                           VIMS_STR("visual-inertial initialisation failed (" << visualInertialInitStatusName(r.status)
                                                                              << "): " << r.message
                                                                              << "; retrying with the next frames"));
    vi_init_frames_.pop_front();
    return false;
  }

  // Build the window from the alignment: poses, velocities, gyro bias, feature depths.
  for (std::size_t k = 0; k < vi_init_frames_.size(); ++k) {
    auto frame = makeFrame(vi_init_frames_[k].frame, vi_init_frames_[k].image, vi_init_frames_[k].t_state);
    setPose(frame->pose, r.T_w_b[k].translation(), Eigen::Quaterniond(r.T_w_b[k].linear()));
    Eigen::Map<Eigen::Matrix<double, 9, 1>> sb(frame->sb);
    sb << r.v_w_b[k], r.accel_bias, r.gyro_bias;
    frame->preintegration = window[k].preintegration;
    if (k == 0) {
      frame->has_first_state_prior = true;
      frame->prior_p = r.T_w_b[0].translation();
      frame->prior_q = Eigen::Quaterniond(r.T_w_b[0].linear());
      frame->prior_sb = sb;
    }
    addObservations(frame.get(), vi_init_frames_[k].frame);
    frames_.push_back(std::move(frame));
  }
  const Eigen::Isometry3d T_bc = extrinsicCamera();
  for (auto& [id, feature] : features_) {
    auto it = r.points_w.find(id);
    if (it == r.points_w.end()) continue;
    const Eigen::Vector3d p_c = (feature.anchor->T_l_b() * T_bc).inverse() * it->second;
    const double lambda = p_c.norm();
    if (p_c.z() > kMinTargetDepth && lambda >= options_.min_feature_depth_m && lambda <= options_.max_feature_depth_m) {
      feature.lambda[0] = lambda;
      feature.has_depth = true;
    }
  }
  vi_init_frames_.clear();
  session_ = session_started_ ? session_ + 1 : 0;
  session_started_ = true;
  last_good_tracking_t_ = tracked.t;
  initializeFeatureDepths();
  logger_->info(kComponent, VIMS_STR("session " << session_ << " initialised at t=" << std::fixed << std::setprecision(3)
                                                << tracked.t << " by visual-inertial alignment over "
                                                << frames_.size() << " frames: " << r.message));
  return true;
}

void VioEstimator::processFrame(const TrackedFrame& tracked, const cv::Mat& image) {
  const auto start = std::chrono::steady_clock::now();
  VioFrameResult result;
  result.t_stamp = tracked.t;
  const double t_state = tracked.t - td_[0];
  result.t_state = t_state;
  auto finish = [&](VioStatus status) {
    result.status = status;
    result.session = session_;
    result.td = td_[0];
    if (!frames_.empty() && status != VioStatus::kReset && status != VioStatus::kWaitingForImu) {
      const Frame& f = *frames_.back();
      if (status != VioStatus::kNoVisualUpdate) {
        result.T_odom_b = f.T_l_b();
        result.v_odom_b = sbVelocity(f.sb);
        result.accel_bias = sbAccelBias(f.sb);
        result.gyro_bias = sbGyroBias(f.sb);
        result.t_state = f.t_state;
      }
      // Move the state to the recorded stamp: dt = td_frame is a few ms, first order is enough.
      const double dt = result.t_stamp - result.t_state;
      Eigen::Vector3d w = Eigen::Vector3d::Zero();
      auto it = std::lower_bound(imu_.begin(), imu_.end(), result.t_state,
                                 [](const ImuSample& s, double value) { return s.t < value; });
      if (it != imu_.end()) w = it->gyro - result.gyro_bias;
      result.T_odom_b_at_stamp = result.T_odom_b;
      result.T_odom_b_at_stamp.translation() += result.v_odom_b * dt;
      result.T_odom_b_at_stamp.linear() =
          (Eigen::Quaterniond(result.T_odom_b.linear()) * so3::exp(w * dt)).normalized().toRotationMatrix();
    }
    result.backend_ms = millisecondsSince(start);
    results_.push_back(result);
  };

  if (frames_.empty()) {
    const bool visual_inertial = !options_.use_sonar && options_.visual_inertial_init.enabled;
    if (!(visual_inertial ? initializeVisualInertial(tracked, image, t_state)
                          : initializeFirstFrame(tracked, image, t_state))) {
      finish(VioStatus::kWaitingForImu);
      return;
    }
    result.features_in_window = 0;
    finish(VioStatus::kInitialized);
    return;
  }

  Frame* prev = frames_.back().get();
  if (t_state <= prev->t_state + 1e-4) {
    logger_->warnThrottled(kComponent, "frame_order", tracked.t, 5.0, "frame state time not after the previous: skipped");
    return;
  }
  const auto samples = imuSamplesForInterval(imu_, prev->t_state, t_state);
  if (!samples || samples->size() < 2) {
    reset("the IMU does not cover the interval to the new frame");
    finish(VioStatus::kReset);
    return;
  }
  auto preint = std::make_shared<ImuPreintegration>(
      ImuPreintegration::fromSamples(*samples, sbAccelBias(prev->sb), sbGyroBias(prev->sb), noise_));
  // IMU prediction of the new state.
  const Eigen::Vector3d p_i = posePosition(prev->pose);
  const Eigen::Quaterniond q_i(poseRotation(prev->pose));
  const Eigen::Vector3d v_i = sbVelocity(prev->sb);
  const double T = preint->deltaTime();
  const Eigen::Vector3d p_pred = p_i + v_i * T + 0.5 * g_l_ * T * T + q_i * preint->alpha();
  const Eigen::Vector3d v_pred = v_i + g_l_ * T + q_i * preint->beta();
  const Eigen::Quaterniond q_pred = (q_i * preint->gamma()).normalized();

  // A frame without features adds nothing but IMU: it is not put in the window; the next frame
  // integrates across it from the newest window frame.
  if (tracked.features.empty()) {
    if (tracked.t - last_good_tracking_t_ > options_.failure_lost_tracking_s) {
      reset(VIMS_STR("no features for " << tracked.t - last_good_tracking_t_ << " s"));
      finish(VioStatus::kReset);
      return;
    }
    logger_->warnThrottled(kComponent, "blank", tracked.t, 5.0, "frame without features: IMU-only propagation");
    result.T_odom_b.linear() = q_pred.toRotationMatrix();
    result.T_odom_b.translation() = p_pred;
    result.v_odom_b = v_pred;
    result.accel_bias = sbAccelBias(prev->sb);
    result.gyro_bias = sbGyroBias(prev->sb);
    finish(VioStatus::kNoVisualUpdate);
    return;
  }

  auto frame = makeFrame(tracked, image, t_state);
  setPose(frame->pose, p_pred, q_pred);
  std::copy(prev->sb, prev->sb + kSpeedBiasSize, frame->sb);
  Eigen::Map<Eigen::Vector3d>(frame->sb) = v_pred;
  frame->preintegration = preint;
  addObservations(frame.get(), tracked);
  int tracked_count = 0;
  for (const auto& entry : frame->obs) tracked_count += prev->obs.count(entry.first) ? 1 : 0;
  frames_.push_back(std::move(frame));
  fillMissingSonarRanges();
  if (tracked_count >= options_.failure_min_tracked) last_good_tracking_t_ = tracked.t;

  // Keyframe decision on the second newest frame (VINS-Mono): it stays when the newest frame
  // tracks few of its features or when it moved enough relative to the frame before it. It
  // depends on the tracks only, so it is taken before the solve, which it selects.
  bool keyframe = true;
  const std::size_t n = frames_.size();
  if (n >= 3) {
    int common = 0;
    const double parallax = parallaxPx(*frames_[n - 3], *frames_[n - 2], &common);
    keyframe = tracked_count < options_.keyframe_min_tracked || common == 0 || parallax >= options_.keyframe_parallax_px;
  }

  initializeFeatureDepths();
  // Until the window is full (session start: the gravity direction, the biases and the first
  // velocities are still being settled) every step optimises the whole, still small, window.
  const bool window_filling = static_cast<int>(frames_.size()) <= options_.window_size;
  if (keyframe || window_filling || options_.solve_window_every_frame) {
    optimize(&result);
  } else {
    optimizeNewest(&result);
  }
  if (options_.use_sonar) updateSeabedFix();
  if (options_.estimate_td && tracked.t - last_td_log_t_ >= 30.0) {
    last_td_log_t_ = tracked.t;
    logger_->info(kComponent, VIMS_STR("camera-IMU time offset td = " << std::fixed << std::setprecision(4) << td_[0]
                                                                       << " s at t=" << std::setprecision(1) << tracked.t));
  }
  removeOutliers();

  std::string why;
  if (detectFailure(p_pred, &why)) {
    reset(why);
    finish(VioStatus::kReset);
    return;
  }

  result.keyframe = keyframe && n >= 2;
  if (keyframe && n >= 2) emitKeyframe(*frames_[n - 2]);
  if (n >= 3) {
    if (keyframe) {
      if (static_cast<int>(frames_.size()) > options_.window_size + 1) marginalizeOldest();
    } else {
      dropSecondNewest();
    }
  }
  pruneImu();
  finish(VioStatus::kTracking);
}

double VioEstimator::parallaxPx(const Frame& a, const Frame& b, int* common) const {
  double sum = 0.0;
  int count = 0;
  for (const auto& [id, obs] : b.obs) {
    auto it = a.obs.find(id);
    if (it == a.obs.end()) continue;
    sum += (obs.fo.uv - it->second.fo.uv).norm();
    ++count;
  }
  *common = count;
  return count > 0 ? focal_ * sum / count : 0.0;
}

// ---------------------------------------------------------------------------------------------
// Feature depths
// ---------------------------------------------------------------------------------------------

Eigen::Vector3d VioEstimator::featureWorld(const Feature& feature) const {
  const Frame::Obs& obs = feature.anchor->obs.at(feature.id);
  const Eigen::Vector3d f_c = feature.lambda[0] * unitBearing(obs.fo, td_[0]);
  return feature.anchor->T_l_b() * (extrinsicCamera() * f_c);
}

Eigen::Vector3d VioEstimator::gyroAt(double t) const {
  if (imu_.empty()) return Eigen::Vector3d::Zero();
  auto it = std::lower_bound(imu_.begin(), imu_.end(), t, [](const ImuSample& s, double value) { return s.t < value; });
  if (it == imu_.begin()) return imu_.front().gyro;
  if (it == imu_.end()) return imu_.back().gyro;
  const ImuSample& a = *(it - 1);
  const double w = (t - a.t) / (it->t - a.t);
  return (1.0 - w) * a.gyro + w * it->gyro;
}

// The td correction uv + (td - td_frame) velocity needs each observation's image velocity. It is
// the velocity the current state predicts, not a difference of the tracker's positions: KLT
// tracks frame to frame, so its position error is a random walk along the track (measured on
// tank60 against the ground-truth projections: 0.22 px rms per frame, 0.5 px at age 2, 3.5 px
// at age 38), and any difference of a track's positions shares increments with the later
// positions of the same track. That correlation biases td (errors in variables): -0.06 s on a
// sequence without offset. For a static point X_c in the camera frame at the state time,
//   dX_c/dt = -w_c x X_c - v_c,   w_c = R_bc^T (gyro - b_g),   v_c = R_bc^T (R_lb^T v_l + w_b x p_bc),
//   d(uv)/dt = (dX_c.xy - uv dX_c.z) / X_c.z,
// with X_c from the feature's anchor and depth. It is refreshed before every solve and held
// constant within it (first order, like the correction itself); an observation of a feature
// without depth gets none (it is in no factor).
void VioEstimator::predictImageVelocities() {
  // Without estimate_td, td == td_frame for every observation: the velocity has no effect.
  if (!options_.estimate_td) return;
  const Eigen::Isometry3d T_b_c = extrinsicCamera();
  const Eigen::Matrix3d R_cb = T_b_c.linear().transpose();
  // World points first: featureWorld reads the anchor observation's current velocity.
  std::map<std::uint64_t, Eigen::Vector3d> points;
  for (const auto& [id, feature] : features_) {
    if (feature.has_depth && feature.lambda[0] > 0.0) points.emplace(id, featureWorld(feature));
  }
  for (auto& frame : frames_) {
    const Eigen::Isometry3d T_l_b = frame->T_l_b();
    const Eigen::Isometry3d T_c_l = (T_l_b * T_b_c).inverse();
    const Eigen::Vector3d w_b = frame->gyro_at_state - sbGyroBias(frame->sb);
    const Eigen::Vector3d w_c = R_cb * w_b;
    const Eigen::Vector3d v_c = R_cb * (T_l_b.linear().transpose() * sbVelocity(frame->sb) + w_b.cross(T_b_c.translation()));
    for (auto& [id, obs] : frame->obs) {
      obs.fo.velocity.setZero();
      auto it = points.find(id);
      if (it == points.end()) continue;
      const Eigen::Vector3d X_c = T_c_l * it->second;
      if (!(X_c.z() > kMinTargetDepth)) continue;
      const Eigen::Vector3d dX_c = -w_c.cross(X_c) - v_c;
      const Eigen::Vector2d uv = X_c.head<2>() / X_c.z();
      const Eigen::Vector2d velocity = (dX_c.head<2>() - uv * dX_c.z()) / X_c.z();
      if (velocity.allFinite()) obs.fo.velocity = velocity;
    }
  }
}

bool VioEstimator::seabedDepth(const Feature& feature, double* lambda) const {
  const Frame& a = *feature.anchor;
  const Eigen::Isometry3d T_l_b = a.T_l_b();
  double seabed_height = 0.0;
  const SonarDepthOptions& sonar_depth = options_.factors.sonar_depth;
  if (a.sonar_range) {
    seabed_height = (T_l_b * (sequence_.sonar.T_b_s * Eigen::Vector3d(0.0, 0.0, *a.sonar_range))).z();
  } else if (seabed_fix_ && sonar_depth.carry_seabed_through_outages &&
             (T_l_b.translation().head<2>() - seabed_fix_->xy).norm() <= sonar_depth.carry_max_distance_m) {
    seabed_height = seabed_fix_->height;  // sonar outage: the last measured seabed
  } else {
    return false;
  }
  const Eigen::Isometry3d T_l_c = T_l_b * extrinsicCamera();
  const Eigen::Vector3d ray = T_l_c.linear() * unitBearing(a.obs.at(feature.id).fo, td_[0]);
  if (ray.z() > -kMinRayDownComponent) return false;
  const double l = (seabed_height - T_l_c.translation().z()) / ray.z();
  if (!(l >= options_.min_feature_depth_m && l <= options_.max_feature_depth_m)) return false;
  *lambda = l;
  return true;
}

bool VioEstimator::triangulate(const Feature& feature, double* lambda) const {
  const Frame& a = *feature.anchor;
  const Eigen::Isometry3d T_l_ca = a.T_l_b() * extrinsicCamera();
  const Eigen::Vector3d ra = T_l_ca.linear() * unitBearing(a.obs.at(feature.id).fo, td_[0]);
  const Eigen::Vector3d ca = T_l_ca.translation();
  double best_angle = 0.0;
  double best_lambda = -1.0;
  for (const auto& frame : frames_) {
    if (frame.get() == &a) continue;
    auto it = frame->obs.find(feature.id);
    if (it == frame->obs.end()) continue;
    const Eigen::Isometry3d T_l_cb = frame->T_l_b() * extrinsicCamera();
    const Eigen::Vector3d rb = T_l_cb.linear() * unitBearing(it->second.fo, td_[0]);
    const double angle = std::acos(std::clamp(ra.dot(rb), -1.0, 1.0));
    if (angle <= best_angle) continue;
    // Closest points of the rays ca + l ra and cb + m rb.
    const Eigen::Vector3d d = T_l_cb.translation() - ca;
    const double a11 = 1.0, a12 = -ra.dot(rb), a22 = 1.0;  // unit rays; system [1 -c; c -1][l m] = [d.ra d.rb]
    const double det = -a11 * a22 + a12 * a12;
    if (std::abs(det) < 1e-12) continue;
    const double b1 = d.dot(ra), b2 = d.dot(rb);
    const double l = (-a22 * b1 - a12 * b2) / det;
    const double m = (a11 * b2 + a12 * b1) / det;
    if (l < options_.min_feature_depth_m || m < options_.min_feature_depth_m || l > options_.max_feature_depth_m) continue;
    best_angle = angle;
    best_lambda = l;
  }
  if (best_lambda <= 0.0 || best_angle < options_.triangulation_min_angle_deg * M_PI / 180.0) return false;
  *lambda = best_lambda;
  return true;
}

void VioEstimator::initializeFeatureDepths() {
  for (auto& [id, feature] : features_) {
    if (feature.has_depth) continue;
    double lambda = 0.0;
    bool ok = false;
    if (options_.use_sonar) ok = seabedDepth(feature, &lambda);
    if (!ok) ok = triangulate(feature, &lambda);
    if (ok) {
      feature.lambda[0] = lambda;
      feature.has_depth = true;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Optimisation
// ---------------------------------------------------------------------------------------------

bool VioEstimator::priorTouches(const MarginalizationPrior& prior, const Frame* frame) {
  for (const double* blk : prior.blocks) {
    if (blk == frame->pose || blk == frame->sb) return true;
  }
  return false;
}

namespace {
/// How features are tied to the seabed: the sonar depth factor where the anchor keyframe has a
/// range, else (outage) a seabed height factor at the last measured height, if any.
struct SeabedTies {
  bool use_sonar = false;
  Eigen::Isometry3d T_b_s = Eigen::Isometry3d::Identity();
  double sonar_sigma = 0.05;
  const SonarDepthOptions* options = nullptr;
  const SeabedFix* carried = nullptr;  ///< the last measured seabed, null before the first range
};

/// Reprojection and sonar residual blocks of one feature at the current estimate.
template <typename FrameT, typename FeatureT>
void featureResiduals(FeatureT& feature, const std::deque<std::unique_ptr<FrameT>>& frames, double* T_b_c, double* td,
                      const Eigen::Matrix2d& sqrt_info, const SeabedTies& seabed, bool apply_gate,
                      std::vector<ResidualSpec>* out) {
  if (!feature.has_depth || !(feature.lambda[0] > 0.0)) return;
  FrameT* a = feature.anchor;
  const auto anchor_it = a->obs.find(feature.id);
  if (anchor_it == a->obs.end()) return;
  const auto& anchor = anchor_it->second.fo;
  const Eigen::Isometry3d T_l_bi = a->T_l_b();
  const Eigen::Isometry3d T_bc = poseBlockToIsometry(T_b_c);
  const std::size_t first = out->size();
  for (const auto& frame : frames) {
    if (frame.get() == a) continue;
    auto it = frame->obs.find(feature.id);
    if (it == frame->obs.end()) continue;
    double z = 0.0;
    reprojectionResidual(anchor, it->second.fo, T_l_bi, frame->T_l_b(), T_bc, feature.lambda[0], td[0], nullptr, &z);
    if (!(z > kMinTargetDepth)) continue;
    ResidualSpec spec;
    spec.cost = new ReprojectionFactor(anchor, it->second.fo, sqrt_info);
    spec.blocks = {a->pose, frame->pose, T_b_c, feature.lambda, td};
    out->push_back(spec);
  }
  if (out->size() == first) return;  // observed in the anchor only: no constraint
  if (!seabed.use_sonar || !feature.sonar_ok) return;
  const SonarDepthOptions& options = *seabed.options;
  if (a->sonar_range) {
    if (apply_gate) {
      const SonarGateResult gate = sonarDepthGate(anchor, *a->sonar_range, seabed.T_b_s, T_l_bi, T_bc,
                                                  feature.lambda[0], td[0], seabed.sonar_sigma, options);
      if (!gate.consistent) feature.sonar_ok = false;
    }
    if (feature.sonar_ok) {
      ResidualSpec spec;
      spec.cost = new SonarDepthFactor(anchor, *a->sonar_range, seabed.T_b_s, seabed.sonar_sigma);
      spec.sonar = true;
      spec.blocks = {a->pose, T_b_c, feature.lambda, td};
      out->push_back(spec);
    }
    return;
  }
  if (!options.carry_seabed_through_outages || !seabed.carried) return;
  const SeabedFix& fix = *seabed.carried;
  const double distance = (T_l_bi.translation().head<2>() - fix.xy).norm();
  if (!(distance <= options.carry_max_distance_m)) return;
  const double sigma = options.carriedSigma(seabed.sonar_sigma, distance);
  // The gate's verdict on a carried height is not kept in sonar_ok: once the sonar is back the
  // anchor's own range judges the feature afresh.
  if (apply_gate &&
      !seabedHeightGate(anchor, fix.height, T_l_bi, T_bc, feature.lambda[0], td[0], sigma, options).consistent)
    return;
  ResidualSpec spec;
  spec.cost = new SeabedHeightFactor(anchor, fix.height, sigma);
  spec.sonar = true;
  spec.blocks = {a->pose, T_b_c, feature.lambda, td};
  out->push_back(spec);
}
}  // namespace

void VioEstimator::optimize(VioFrameResult* result) {
  predictImageVelocities();
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold pose_manifold;
  ceres::HuberLoss huber(options_.reprojection_loss_scale);
  ceres::CauchyLoss cauchy(options_.sonar_loss_scale);

  for (auto& frame : frames_) {
    problem.AddParameterBlock(frame->pose, kPoseSize, &pose_manifold);
    problem.AddParameterBlock(frame->sb, kSpeedBiasSize);
  }
  problem.AddParameterBlock(T_b_c_block_, kPoseSize, &pose_manifold);
  problem.SetParameterBlockConstant(T_b_c_block_);
  problem.AddParameterBlock(td_, 1);
  // Mean image speed of the window's tracked observations: td is only estimated with motion.
  double speed_sum = 0.0;
  int speed_count = 0;
  for (const auto& frame : frames_) {
    for (const auto& [id, obs] : frame->obs) {
      if (obs.fo.velocity.isZero()) continue;  // new feature: no velocity yet
      speed_sum += focal_ * obs.fo.velocity.norm();
      ++speed_count;
    }
  }
  const bool td_observable = speed_count > 0 && speed_sum / speed_count > options_.td_min_image_speed_px_s;
  if (options_.estimate_td && td_observable) {
    problem.SetParameterLowerBound(td_, 0, -options_.max_abs_td_s);
    problem.SetParameterUpperBound(td_, 0, options_.max_abs_td_s);
  } else {
    problem.SetParameterBlockConstant(td_);
  }

  for (std::size_t i = 1; i < frames_.size(); ++i) {
    Frame* fi = frames_[i - 1].get();
    Frame* fj = frames_[i].get();
    fj->preintegration->repropagateIfNeeded(sbAccelBias(fi->sb), sbGyroBias(fi->sb),
                                            options_.factors.imu_preintegration);
    problem.AddResidualBlock(new ImuFactor(fj->preintegration, g_l_), nullptr, fi->pose, fi->sb, fj->pose, fj->sb);
  }
  for (const auto& prior : priors_) problem.AddResidualBlock(new MarginalizationFactor(prior), nullptr, prior->blocks);
  Frame* first = frames_.front().get();
  if (first->has_first_state_prior) {
    problem.AddResidualBlock(new PosePriorFactor(first->prior_p, first->prior_q,
                                                 PosePriorFactor::positionYawSqrtInformation(kGaugeSigmaPosition,
                                                                                             kGaugeSigmaYaw)),
                             nullptr, first->pose);
    Eigen::Matrix<double, 9, 1> inv_sigma;
    inv_sigma << Eigen::Vector3d::Constant(1.0 / options_.init_velocity_sigma),
        Eigen::Vector3d::Constant(1.0 / options_.init_accel_bias_sigma),
        Eigen::Vector3d::Constant(1.0 / options_.init_gyro_bias_sigma);
    problem.AddResidualBlock(new SpeedBiasPriorFactor(first->prior_sb, inv_sigma), nullptr, first->sb);
  }

  const Eigen::Matrix2d sqrt_info = ReprojectionFactor::sqrtInformation(
      sequence_.camera.fx, sequence_.camera.fy, options_.factors.reprojection.pixel_sigma);
  int n_features = 0, n_sonar = 0;
  const SeabedTies seabed{options_.use_sonar, sequence_.sonar.T_b_s, sonar_sigma_, &options_.factors.sonar_depth,
                          seabed_fix_ ? &*seabed_fix_ : nullptr};
  std::vector<ResidualSpec> specs;
  for (auto& [id, feature] : features_) {
    specs.clear();
    featureResiduals(feature, frames_, T_b_c_block_, td_, sqrt_info, seabed, true, &specs);
    if (specs.empty()) continue;
    problem.AddParameterBlock(feature.lambda, 1);
    problem.SetParameterLowerBound(feature.lambda, 0, options_.min_feature_depth_m);
    problem.SetParameterUpperBound(feature.lambda, 0, options_.max_feature_depth_m);
    ++n_features;
    for (const ResidualSpec& s : specs) {
      if (s.sonar) ++n_sonar;
      problem.AddResidualBlock(s.cost, s.sonar ? static_cast<ceres::LossFunction*>(&cauchy) : &huber, s.blocks);
    }
  }
  if (n_features == 0 && options_.estimate_td && td_observable) problem.SetParameterBlockConstant(td_);  // no visual factor

  ceres::Solver::Summary summary;
  ceres::Solve(windowSolverOptions(options_, ceres::DENSE_SCHUR), &problem, &summary);
  result->features_in_window = n_features;
  result->sonar_factors = n_sonar;
}

void VioEstimator::optimizeNewest(VioFrameResult* result) {
  // Only the newest frame's pose and speed-bias are free; the previous frame's state, the
  // anchors' poses, the depths, T_b_c and td are constants. Residuals: the IMU factor from the
  // previous frame and the newest frame's reprojections of every landmark anchored elsewhere.
  // Features anchored in the newest frame (new ones) constrain nothing yet.
  predictImageVelocities();
  const std::size_t n = frames_.size();
  Frame* prev = frames_[n - 2].get();
  Frame* newest = frames_[n - 1].get();
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold pose_manifold;
  ceres::HuberLoss huber(options_.reprojection_loss_scale);

  auto add_constant = [&](double* block, int size, ceres::Manifold* manifold) {
    if (problem.HasParameterBlock(block)) return;
    problem.AddParameterBlock(block, size, manifold);
    problem.SetParameterBlockConstant(block);
  };
  problem.AddParameterBlock(newest->pose, kPoseSize, &pose_manifold);
  problem.AddParameterBlock(newest->sb, kSpeedBiasSize);
  add_constant(prev->pose, kPoseSize, &pose_manifold);
  add_constant(prev->sb, kSpeedBiasSize, nullptr);
  add_constant(T_b_c_block_, kPoseSize, &pose_manifold);
  add_constant(td_, 1, nullptr);
  newest->preintegration->repropagateIfNeeded(sbAccelBias(prev->sb), sbGyroBias(prev->sb),
                                              options_.factors.imu_preintegration);
  problem.AddResidualBlock(new ImuFactor(newest->preintegration, g_l_), nullptr, prev->pose, prev->sb, newest->pose,
                           newest->sb);

  const Eigen::Matrix2d sqrt_info = ReprojectionFactor::sqrtInformation(
      sequence_.camera.fx, sequence_.camera.fy, options_.factors.reprojection.pixel_sigma);
  const Eigen::Isometry3d T_bc = extrinsicCamera();
  const Eigen::Isometry3d T_l_bk = newest->T_l_b();
  int n_features = 0;
  for (auto& [id, feature] : features_) {
    if (!feature.has_depth || !(feature.lambda[0] > 0.0) || feature.anchor == newest) continue;
    auto it = newest->obs.find(id);
    if (it == newest->obs.end()) continue;
    const auto& anchor = feature.anchor->obs.at(id).fo;
    double z = 0.0;
    reprojectionResidual(anchor, it->second.fo, feature.anchor->T_l_b(), T_l_bk, T_bc, feature.lambda[0], td_[0],
                         nullptr, &z);
    if (!(z > kMinTargetDepth)) continue;
    add_constant(feature.anchor->pose, kPoseSize, &pose_manifold);
    add_constant(feature.lambda, 1, nullptr);
    problem.AddResidualBlock(new ReprojectionFactor(anchor, it->second.fo, sqrt_info), &huber, feature.anchor->pose,
                             newest->pose, T_b_c_block_, feature.lambda, td_);
    ++n_features;
  }

  ceres::Solver::Summary summary;
  // 15 unknowns: nothing to eliminate.
  ceres::Solve(windowSolverOptions(options_, ceres::DENSE_QR), &problem, &summary);
  result->features_in_window = n_features;
  result->sonar_factors = 0;
}

void VioEstimator::fillMissingSonarRanges() {
  if (!options_.use_sonar) return;
  for (auto& frame : frames_) {
    if (!frame->sonar_range) frame->sonar_range = sonarRangeAt(frame->t_state);
  }
  // The newest frame's range may still be on its way; one frame later a missing range is a gap.
  const std::size_t n = frames_.size();
  if (n >= 2 && !frames_[n - 2]->sonar_range) {
    const Frame& f = *frames_[n - 2];
    std::ostringstream fallback;
    fallback << std::fixed << std::setprecision(3);
    if (seabed_fix_ && options_.factors.sonar_depth.carry_seabed_through_outages)
      fallback << "features held at the seabed height the sonar last measured (z=" << seabed_fix_->height
               << " m at t=" << seabed_fix_->t << ") within " << options_.factors.sonar_depth.carry_max_distance_m
               << " m of it, visual-inertial beyond";
    else
      fallback << "visual-inertial only until it returns";
    logger_->warnThrottled(kComponent, "no_sonar", f.t_stamp, 10.0,
                           VIMS_STR("sonar gap: no filtered range within " << options_.sonar_max_interpolation_gap_s
                                                                            << " s of the frame at t=" << std::fixed
                                                                            << std::setprecision(3) << f.t_stamp << ": "
                                                                            << fallback.str()));
  }
}

void VioEstimator::updateSeabedFix() {
  for (auto it = frames_.rbegin(); it != frames_.rend(); ++it) {
    const Frame& f = **it;
    if (!f.sonar_range) continue;
    if (seabed_fix_ && seabed_fix_->t > f.t_state) return;  // an older frame: keep the newer fix
    const Eigen::Isometry3d T_l_b = f.T_l_b();
    SeabedFix fix;
    fix.height = (T_l_b * (sequence_.sonar.T_b_s * Eigen::Vector3d(0.0, 0.0, *f.sonar_range))).z();
    fix.xy = T_l_b.translation().head<2>();
    fix.t = f.t_state;
    if (!std::isfinite(fix.height) || !fix.xy.allFinite()) return;
    seabed_fix_ = fix;
    return;
  }
}

void VioEstimator::removeOutliers() {
  const Eigen::Isometry3d T_bc = extrinsicCamera();
  std::vector<std::uint64_t> remove;
  for (auto& [id, feature] : features_) {
    if (!feature.has_depth) continue;
    if (!std::isfinite(feature.lambda[0]) || feature.lambda[0] < options_.min_feature_depth_m ||
        feature.lambda[0] > options_.max_feature_depth_m) {
      feature.has_depth = false;  // re-initialised from the seabed or triangulation
      continue;
    }
    const auto& anchor = feature.anchor->obs.at(id).fo;
    const Eigen::Isometry3d T_l_bi = feature.anchor->T_l_b();
    for (const auto& frame : frames_) {
      if (frame.get() == feature.anchor) continue;
      auto it = frame->obs.find(id);
      if (it == frame->obs.end()) continue;
      double z = 0.0;
      const Eigen::Vector2d r = reprojectionResidual(anchor, it->second.fo, T_l_bi, frame->T_l_b(), T_bc,
                                                     feature.lambda[0], td_[0], nullptr, &z);
      if (z > kMinTargetDepth && focal_ * r.norm() <= options_.outlier_reprojection_px) continue;
      remove.push_back(id);
      break;
    }
  }
  for (std::uint64_t id : remove) {
    for (auto& frame : frames_) frame->obs.erase(id);
    features_.erase(id);
  }
}

bool VioEstimator::detectFailure(const Eigen::Vector3d& p_pred, std::string* why) const {
  for (const auto& frame : frames_) {
    if (!finiteState(frame->pose, frame->sb)) {
      *why = "non-finite state";
      return true;
    }
  }
  if (!std::isfinite(td_[0])) {
    *why = "non-finite td";
    return true;
  }
  const Frame& f = *frames_.back();
  if (sbAccelBias(f.sb).norm() > options_.failure_max_accel_bias) {
    *why = VIMS_STR("accelerometer bias estimate " << sbAccelBias(f.sb).norm() << " m/s^2 too large");
    return true;
  }
  if (sbGyroBias(f.sb).norm() > options_.failure_max_gyro_bias) {
    *why = VIMS_STR("gyro bias estimate " << sbGyroBias(f.sb).norm() << " rad/s too large");
    return true;
  }
  if (sbVelocity(f.sb).norm() > options_.failure_max_velocity) {
    *why = VIMS_STR("velocity estimate " << sbVelocity(f.sb).norm() << " m/s too large");
    return true;
  }
  const double jump = (posePosition(f.pose) - p_pred).norm();
  if (jump > options_.failure_max_position_jump_m) {
    *why = VIMS_STR("position jumped " << jump << " m from the IMU prediction");
    return true;
  }
  if (f.t_stamp - last_good_tracking_t_ > options_.failure_lost_tracking_s) {
    *why = VIMS_STR("fewer than " << options_.failure_min_tracked << " tracked features for "
                                  << f.t_stamp - last_good_tracking_t_ << " s");
    return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// Sliding the window
// ---------------------------------------------------------------------------------------------

void VioEstimator::reanchorFeaturesOf(const Frame* frame) {
  // Features anchored in `frame` move to their next observing frame: the point is transferred
  // (with the current depth) and lambda becomes its distance from the new anchor camera.
  const Eigen::Isometry3d T_bc = extrinsicCamera();
  std::vector<std::uint64_t> remove;
  for (auto& [id, feature] : features_) {
    if (feature.anchor != frame) continue;
    Frame* next = nullptr;
    for (const auto& f : frames_) {
      if (f.get() != frame && f->obs.count(id)) {
        next = f.get();
        break;
      }
    }
    if (next == nullptr) {
      remove.push_back(id);
      continue;
    }
    if (feature.has_depth) {
      const Eigen::Vector3d p_l = featureWorld(feature);
      const Eigen::Vector3d p_c = (next->T_l_b() * T_bc).inverse() * p_l;
      if (p_c.z() > kMinTargetDepth && std::isfinite(p_c.norm())) {
        feature.lambda[0] = p_c.norm();
      } else {
        feature.has_depth = false;
      }
    }
    feature.anchor = next;
    feature.sonar_ok = true;  // the new anchor has its own sonar range; the gate judges again
  }
  for (std::uint64_t id : remove) {
    for (auto& f : frames_) f->obs.erase(id);
    features_.erase(id);
  }
}

void VioEstimator::marginalizeOldest() {
  Frame* old = frames_.front().get();
  Frame* next = frames_[1].get();
  MarginalizationInfo info(options_.factors.marginalization);
  std::vector<double*> drop = {old->pose, old->sb};
  auto declare_frame = [&](Frame* f) {
    info.addParameterBlock(f->pose, kPoseSize, BlockManifold::kPose);
    info.addParameterBlock(f->sb, kSpeedBiasSize, BlockManifold::kEuclidean);
  };
  for (auto& f : frames_) declare_frame(f.get());
  info.addParameterBlock(T_b_c_block_, kPoseSize, BlockManifold::kPose);
  info.addParameterBlock(td_, 1, BlockManifold::kEuclidean);
  try {
    // Priors that touch the dropped states are folded into the new one; the others stay.
    std::vector<std::shared_ptr<const MarginalizationPrior>> untouched;
    for (const auto& prior : priors_) {
      if (priorTouches(*prior, old)) {
        info.addResidualBlock(std::make_shared<MarginalizationFactor>(prior), nullptr, prior->blocks);
      } else {
        untouched.push_back(prior);
      }
    }
    info.addResidualBlock(std::make_shared<ImuFactor>(next->preintegration, g_l_), nullptr,
                          {old->pose, old->sb, next->pose, next->sb});
    if (old->has_first_state_prior) {
      info.addResidualBlock(std::make_shared<PosePriorFactor>(
                                old->prior_p, old->prior_q,
                                PosePriorFactor::positionYawSqrtInformation(kGaugeSigmaPosition, kGaugeSigmaYaw)),
                            nullptr, {old->pose});
      Eigen::Matrix<double, 9, 1> inv_sigma;
      inv_sigma << Eigen::Vector3d::Constant(1.0 / options_.init_velocity_sigma),
          Eigen::Vector3d::Constant(1.0 / options_.init_accel_bias_sigma),
          Eigen::Vector3d::Constant(1.0 / options_.init_gyro_bias_sigma);
      info.addResidualBlock(std::make_shared<SpeedBiasPriorFactor>(old->prior_sb, inv_sigma), nullptr, {old->sb});
    }
    const Eigen::Matrix2d sqrt_info = ReprojectionFactor::sqrtInformation(
        sequence_.camera.fx, sequence_.camera.fy, options_.factors.reprojection.pixel_sigma);
    auto huber = std::make_shared<ceres::HuberLoss>(options_.reprojection_loss_scale);
    auto cauchy = std::make_shared<ceres::CauchyLoss>(options_.sonar_loss_scale);
    const SeabedTies seabed{options_.use_sonar, sequence_.sonar.T_b_s, sonar_sigma_, &options_.factors.sonar_depth,
                            seabed_fix_ ? &*seabed_fix_ : nullptr};
    std::vector<ResidualSpec> specs;
    for (auto& [id, feature] : features_) {
      if (feature.anchor != old) continue;
      specs.clear();
      featureResiduals(feature, frames_, T_b_c_block_, td_, sqrt_info, seabed, false, &specs);
      if (specs.empty()) continue;
      info.addParameterBlock(feature.lambda, 1, BlockManifold::kEuclidean);
      drop.push_back(feature.lambda);
      for (const ResidualSpec& s : specs) {
        std::shared_ptr<const ceres::LossFunction> loss =
            s.sonar ? std::static_pointer_cast<const ceres::LossFunction>(cauchy)
                    : std::static_pointer_cast<const ceres::LossFunction>(huber);
        info.addResidualBlock(std::shared_ptr<const ceres::CostFunction>(s.cost), loss, s.blocks);
      }
    }
    // With estimate_td, td stays in the prior: one window of this slow motion observes it only
    // to about +-0.1 s (the tracker's random-walk errors, see predictImageVelocities), so the
    // estimate needs the information of every window since the start (tank60, tracker
    // features: the final td went from a wandering -0.08 s to a steady -0.002 s). Without
    // estimate_td it is marginalised as before.
    if (!options_.estimate_td) drop.push_back(td_);
    auto prior = info.marginalize(drop);
    priors_ = untouched;
    if (prior) priors_.push_back(prior);
  } catch (const std::exception& e) {
    logger_->warn(kComponent, std::string("marginalisation failed, priors dropped: ") + e.what());
    priors_.clear();
  }
  const bool had_gauge = old->has_first_state_prior;
  reanchorFeaturesOf(old);
  frames_.pop_front();
  next->preintegration.reset();
  if (priors_.empty()) {
    // Without a prior the gauge would float: pin the new oldest frame where it is.
    next->has_first_state_prior = true;
    next->prior_p = posePosition(next->pose);
    next->prior_q = Eigen::Quaterniond(poseRotation(next->pose));
    next->prior_sb = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(next->sb);
    if (!had_gauge) logger_->warn(kComponent, "no marginalisation prior: the gauge is re-pinned at the oldest frame");
  }
}

void VioEstimator::dropSecondNewest() {
  const std::size_t n = frames_.size();
  Frame* a = frames_[n - 3].get();
  Frame* b = frames_[n - 2].get();
  Frame* c = frames_[n - 1].get();
  std::vector<std::shared_ptr<const MarginalizationPrior>> kept;
  for (const auto& prior : priors_) {
    if (!priorTouches(*prior, b)) {
      kept.push_back(prior);
      continue;
    }
    // Only the prior knows this frame's states (its visual factors are simply dropped, as in
    // VINS-Mono): marginalise them out of it.
    MarginalizationInfo info(options_.factors.marginalization);
    for (std::size_t i = 0; i < prior->blocks.size(); ++i) {
      info.addParameterBlock(prior->blocks[i], prior->ambient_sizes[i], prior->manifolds[i]);
    }
    try {
      info.addResidualBlock(std::make_shared<MarginalizationFactor>(prior), nullptr, prior->blocks);
      std::vector<double*> drop;
      for (double* blk : {b->pose, b->sb}) {
        if (std::find(prior->blocks.begin(), prior->blocks.end(), blk) != prior->blocks.end()) drop.push_back(blk);
      }
      auto reduced = info.marginalize(drop);
      if (reduced) kept.push_back(reduced);
    } catch (const std::exception& e) {
      logger_->warn(kComponent, std::string("marginalisation failed, prior dropped: ") + e.what());
    }
  }
  priors_ = kept;
  // Merge the IMU intervals a->b and b->c into a->c (shared boundary sample counted once).
  std::vector<ImuSample> samples = b->preintegration->samples();
  const auto& tail = c->preintegration->samples();
  samples.insert(samples.end(), tail.begin() + 1, tail.end());
  c->preintegration = std::make_shared<ImuPreintegration>(
      ImuPreintegration::fromSamples(samples, sbAccelBias(a->sb), sbGyroBias(a->sb), noise_));
  reanchorFeaturesOf(b);
  frames_.erase(frames_.begin() + static_cast<long>(n - 2));
  if (priors_.empty() && !frames_.front()->has_first_state_prior) {
    Frame* f = frames_.front().get();
    f->has_first_state_prior = true;
    f->prior_p = posePosition(f->pose);
    f->prior_q = Eigen::Quaterniond(poseRotation(f->pose));
    f->prior_sb = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(f->sb);
  }
}

void VioEstimator::emitKeyframe(Frame& frame) {
  if (frame.keyframe_emitted) return;
  frame.keyframe_emitted = true;
  KeyframeData kf;
  kf.t = frame.t_state;
  kf.session = session_;
  kf.T_odom_b = frame.T_l_b();
  kf.image = frame.image;
  for (const auto& [id, obs] : frame.obs) {
    auto it = features_.find(id);
    if (it == features_.end() || !it->second.has_depth) continue;
    KeyframeLandmark f;
    f.id = id;
    f.p_odom = featureWorld(it->second);
    f.pixel = obs.pixel;
    f.normalized = obs.fo.uv;
    kf.features.push_back(f);
  }
  keyframes_.push_back(std::move(kf));
}

void VioEstimator::pruneImu() {
  if (imu_.empty()) return;
  double keep_from = frames_.empty() ? imu_.back().t - 2.0 * options_.init_gravity_window_s
                                     : frames_.front()->t_state - 1.0;
  if (frames_.empty() && !vi_init_frames_.empty()) keep_from = std::min(keep_from, vi_init_frames_.front().t_state - 1.0);
  auto it = std::lower_bound(imu_.begin(), imu_.end(), keep_from,
                             [](const ImuSample& s, double value) { return s.t < value; });
  if (it != imu_.begin() && it - imu_.begin() > 200) imu_.erase(imu_.begin(), it);
  while (!sonar_.empty() && sonar_.front().first < keep_from) sonar_.pop_front();
}

}  // namespace vims
