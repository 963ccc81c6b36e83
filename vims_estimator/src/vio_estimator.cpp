// Input, session start and frame processing of the sliding-window VIO.
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
#include "vio_window.h"

namespace vims {

using namespace vio_window;

namespace {

constexpr const char* kComponent = "vio";

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
    case VioStatus::kWaitingForImu:
      return "waiting_for_imu";
    case VioStatus::kInitialized:
      return "initialized";
    case VioStatus::kTracking:
      return "tracking";
    case VioStatus::kNoVisualUpdate:
      return "no_visual_update";
    case VioStatus::kReset:
      return "reset";
  }
  return "unknown";
}

// ---------------------------------------------------------------------------------------------
// Construction and input
// ---------------------------------------------------------------------------------------------

VioEstimator::VioEstimator(const SequenceConfig& sequence, const EstimatorOptions& options, LoggerPtr logger)
    : sequence_(sequence),
      options_(options),
      logger_(std::move(logger)),
      camera_(sequence.camera),
      weigh_through_lens_(
          weighsThroughLens(options.factors.reprojection.lens_weighting, sequence.camera.distortion_model)),
      seabed_relief_(static_cast<std::size_t>(options.factors.sonar_depth.misfit_history_hits)) {
  noise_ = ImuNoiseParams::fromCalibration(sequence_.imu);
  g_l_ = Eigen::Vector3d(0.0, 0.0, -sequence_.imu.gravity);
  focal_ = 0.5 * (sequence_.camera.fx + sequence_.camera.fy);
  if (!(focal_ > 0.0)) throw std::invalid_argument("VioEstimator: camera focal length must be > 0");
  sonar_sigma_ =
      options_.factors.sonar_depth.sigma(std::max(sequence_.sonar.range_noise_std, options_.sonar_min_range_std_m));
  isometryToPoseBlock(sequence_.camera.T_b_c, T_b_c_block_);
  td_[0] = options_.td_initial_s;
  if (sequence_.pressure && options_.pressure.enabled) {
    pressure_filter_ =
        std::make_unique<PressureDepthFilter>(*sequence_.pressure, sequence_.imu.gravity, options_.pressure);
    pressure_sigma_ = std::max(sequence_.pressure->depthStd(sequence_.imu.gravity), options_.pressure.min_depth_std_m);
  }
}

VioEstimator::~VioEstimator() = default;

Eigen::Isometry3d VioEstimator::extrinsicCamera() const { return poseBlockToIsometry(T_b_c_block_); }

std::string extrinsicChange(const Eigen::Isometry3d& yaml_T_b_c, const Eigen::Isometry3d& estimated_T_b_c) {
  const double rotation_deg =
      Eigen::AngleAxisd(yaml_T_b_c.linear().transpose() * estimated_T_b_c.linear()).angle() * 180.0 / M_PI;
  const double translation_m = (estimated_T_b_c.translation() - yaml_T_b_c.translation()).norm();
  std::ostringstream os;
  os << std::fixed << std::setprecision(3) << "rotation " << rotation_deg << " deg, translation "
     << std::setprecision(4) << translation_m << " m from the sequence YAML's; T_b_c = [" << std::setprecision(9);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) os << estimated_T_b_c.matrix()(r, c) << (r == 3 && c == 3 ? "]" : ", ");
  return os.str();
}

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
  seabed_relief_.clear();
  relief_.reset();
  surface_initialized_ = false;
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
      pressure_.clear();
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
    if (result.t < sonar_.back().first)
      sonar_.clear();  // clock went backwards: old ranges are void
    else
      return;
  }
  sonar_.emplace_back(result.t, result.filtered);
  processPendingFrames();  // a frame may have been waiting for this range
}

void VioEstimator::feedPressure(const PressureSample& sample) {
  if (!pressure_filter_) return;  // no pressure sensor in the sequence, or the factor is off
  const PressureDepthFilter::Result r = pressure_filter_->add(sample);
  if (!r.accepted) {
    logger_->warnThrottled(kComponent, "pressure_bad", std::isfinite(sample.t) ? sample.t : 0.0, 10.0,
                           "dropping a pressure sample at t=" + std::to_string(sample.t) + ": " + r.rejected_because);
    return;
  }
  if (r.depth < -1.0 && !warned_above_surface_) {
    warned_above_surface_ = true;
    logger_->warn(kComponent, VIMS_STR("pressure depth "
                                       << r.depth
                                       << " m is above the surface: the sequence's "
                                          "pressure.atmospheric_pa is probably wrong; depths are used relative to an "
                                          "estimated surface, so the factor still holds"));
  }
  if (!pressure_.empty() && r.t < pressure_.back().first) pressure_.clear();  // clock went backwards
  pressure_.emplace_back(r.t, r.depth);
  processPendingFrames();  // a frame may have been waiting for this depth
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
        imu_.back().t < t_needed + rangeWaitS(sequence_.sonar.rate_hz))
      return;
    // The same for the pressure depth (its own topic online): the same wait, so a frame gets the
    // same interpolated depth live as offline.
    if (usePressure() && options_.sonar_wait_s > 0.0 && (pressure_.empty() || pressure_.back().first < t_needed) &&
        imu_.back().t < t_needed + rangeWaitS(sequence_.pressure->rate_hz))
      return;
    auto [frame, image] = std::move(pending_.front());
    pending_.pop_front();
    processFrame(frame, image);
  }
}

std::optional<double> VioEstimator::sonarRangeAt(double t) const {
  return interpolateSeries(sonar_, t, sonarInterpolationGapS());
}

// The two options are in seconds, set for the contract's 10 Hz sonar; a slower one (the contract
// allows 1 Hz) needs at least its own sample periods, read from the sequence YAML.
double VioEstimator::sonarInterpolationGapS() const {
  return std::max(options_.sonar_max_interpolation_gap_s, 2.5 / sequence_.sonar.rate_hz);
}

double VioEstimator::rangeWaitS(double rate_hz) const { return std::max(options_.sonar_wait_s, 1.5 / rate_hz); }

std::optional<double> VioEstimator::pressureDepthAt(double t) const {
  if (!usePressure()) return std::nullopt;
  // Three sample periods of the sequence's rate: one or two lost samples are interpolated over.
  return interpolateSeries(pressure_, t, 3.0 / sequence_.pressure->rate_hz);
}

std::unique_ptr<VioEstimator::Frame> VioEstimator::makeFrame(const TrackedFrame& tracked, const cv::Mat& image,
                                                             double t_state) {
  auto frame = std::make_unique<Frame>();
  frame->t_stamp = tracked.t;
  frame->t_state = t_state;
  frame->gyro_at_state = gyroAt(t_state);
  frame->image = image;
  if (options_.use_sonar) frame->sonar_range = sonarRangeAt(t_state);
  frame->depth = pressureDepthAt(t_state);
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
    obs.pixel_from_uv = pixelFromNormalizedJacobian(camera_, tf.normalized, weigh_through_lens_);
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
  const bool is_static =
      std::sqrt(acc_var / n) < options_.init_static_accel_std && std::sqrt(gyr_var / n) < options_.init_static_gyro_std;
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
  logger_->info(kComponent,
                VIMS_STR("session " << session_ << " initialised at t=" << std::fixed << std::setprecision(3)
                                    << tracked.t << (is_static ? " (static start)" : " (moving start: v0 = 0 assumed)")
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
    logger_->warnThrottled(
        kComponent, "vi_init", tracked.t, 5.0,
        VIMS_STR("visual-inertial initialisation failed (" << visualInertialInitStatusName(r.status)
                                                           << "): " << r.message << "; retrying with the next frames"));
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
  logger_->info(
      kComponent,
      VIMS_STR("session " << session_ << " initialised at t=" << std::fixed << std::setprecision(3) << tracked.t
                          << " by visual-inertial alignment over " << frames_.size() << " frames: " << r.message));
  return true;
}

void VioEstimator::completeResult(VioStatus status, VioFrameResult* result) const {
  result->status = status;
  result->session = session_;
  result->td = td_[0];
  if (!frames_.empty() && status != VioStatus::kReset && status != VioStatus::kWaitingForImu) {
    const Frame& f = *frames_.back();
    if (status != VioStatus::kNoVisualUpdate) {
      result->T_odom_b = f.T_l_b();
      result->v_odom_b = sbVelocity(f.sb);
      result->accel_bias = sbAccelBias(f.sb);
      result->gyro_bias = sbGyroBias(f.sb);
      result->t_state = f.t_state;
    }
    // Move the state to the recorded stamp: dt = td_frame is a few ms, first order is enough.
    const double dt = result->t_stamp - result->t_state;
    Eigen::Vector3d w = Eigen::Vector3d::Zero();
    auto it = std::lower_bound(imu_.begin(), imu_.end(), result->t_state,
                               [](const ImuSample& s, double value) { return s.t < value; });
    if (it != imu_.end()) w = it->gyro - result->gyro_bias;
    result->T_odom_b_at_stamp = result->T_odom_b;
    result->T_odom_b_at_stamp.translation() += result->v_odom_b * dt;
    result->T_odom_b_at_stamp.linear() =
        (Eigen::Quaterniond(result->T_odom_b.linear()) * so3::exp(w * dt)).normalized().toRotationMatrix();
    result->seabed_slope = Eigen::Vector2d(f.slope[0], f.slope[1]);
    if (f.sonar_range) result->sonar_hit = f.T_l_b() * sonarHitInBody(*f.sonar_range, sequence_.sonar.T_b_s);
    if (seabed_fix_) {
      const SeabedPlane plane{seabed_fix_->height, seabed_fix_->xy, seabed_fix_->slope};
      result->seabed_height = plane.heightAt(result->T_odom_b.translation().head<2>());
    }
  }
}

void VioEstimator::processFrame(const TrackedFrame& tracked, const cv::Mat& image) {
  const auto start = std::chrono::steady_clock::now();
  VioFrameResult result;
  result.t_stamp = tracked.t;
  const double t_state = tracked.t - td_[0];
  result.t_state = t_state;
  auto finish = [&](VioStatus status) {
    completeResult(status, &result);
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
    logger_->warnThrottled(kComponent, "frame_order", tracked.t, 5.0,
                           "frame state time not after the previous: skipped");
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
  std::copy(prev->slope, prev->slope + 2, frame->slope);
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
    keyframe =
        tracked_count < options_.keyframe_min_tracked || common == 0 || parallax >= options_.keyframe_parallax_px;
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
    logger_->info(kComponent,
                  VIMS_STR("camera-IMU time offset td = " << std::fixed << std::setprecision(4) << td_[0]
                                                          << " s at t=" << std::setprecision(1) << tracked.t));
  }
  if (options_.estimate_extrinsic && tracked.t - last_extrinsic_log_t_ >= 30.0) {
    last_extrinsic_log_t_ = tracked.t;
    logger_->info(kComponent,
                  VIMS_STR("camera-IMU extrinsic at t=" << std::fixed << std::setprecision(1) << tracked.t << ": "
                                                        << extrinsicChange(sequence_.camera.T_b_c, extrinsicCamera())));
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

void VioEstimator::emitKeyframe(Frame& frame) {
  if (frame.keyframe_emitted) return;
  frame.keyframe_emitted = true;
  KeyframeData kf;
  kf.t = frame.t_state;
  kf.session = session_;
  kf.T_odom_b = frame.T_l_b();
  kf.port_depth = frame.depth;
  kf.image = frame.image;
  if (options_.estimate_extrinsic) kf.T_b_c = extrinsicCamera();
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
  double keep_from =
      frames_.empty() ? imu_.back().t - 2.0 * options_.init_gravity_window_s : frames_.front()->t_state - 1.0;
  if (frames_.empty() && !vi_init_frames_.empty())
    keep_from = std::min(keep_from, vi_init_frames_.front().t_state - 1.0);
  auto it = std::lower_bound(imu_.begin(), imu_.end(), keep_from,
                             [](const ImuSample& s, double value) { return s.t < value; });
  if (it != imu_.begin() && it - imu_.begin() > 200) imu_.erase(imu_.begin(), it);
  while (!sonar_.empty() && sonar_.front().first < keep_from) sonar_.pop_front();
  while (!pressure_.empty() && pressure_.front().first < keep_from) pressure_.pop_front();
}

}  // namespace vims
