#pragma once
/// @file vio_estimator.h
/// @brief The sliding-window visual-inertial-sonar odometry (the paper's "local VIO"): keyframe
/// states, direct feature depths and the camera-IMU time offset optimised with Ceres over IMU,
/// reprojection and sonar depth factors, with marginalisation of the oldest keyframe (or of the
/// newest non-keyframe) into a prior. ROS-free, synchronous and deterministic: every output is a
/// function of the fed data only. docs/estimator.md describes the algorithm and its rules for bad
/// input.
///
/// Usage: feed IMU samples, filtered sonar ranges and tracked frames in (roughly) time order;
/// frames are processed as soon as the IMU covers their time. After each feed call, drain
/// takeFrameResults() and takeKeyframes().

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

namespace ceres {
class Problem;
class LossFunction;
}  // namespace ceres
#include <deque>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "vims_common/camera_model.h"
#include "vims_common/keyframe_data.h"
#include "vims_common/log.h"
#include "vims_common/sensor_data.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sonar_altitude.h"
#include "vims_common/tracked_frame.h"
#include "vims_estimator/estimator_options.h"
#include "vims_estimator/imu_preintegration.h"
#include "vims_estimator/marginalization.h"
#include "vims_estimator/pressure_depth_filter.h"
#include "vims_estimator/seabed_relief.h"

namespace vims {
namespace vio_window {
struct SeabedTies;
struct HitTie;
}  // namespace vio_window

/// What the estimator did with a frame.
enum class VioStatus {
  kWaitingForImu,   ///< not enough IMU before the first frame to find gravity: frame skipped
  kInitialized,     ///< this frame started a session (gravity-aligned first state)
  kTracking,        ///< normal operation: window optimised
  kNoVisualUpdate,  ///< blank/feature-less frame: state propagated by the IMU (and sonar) only
  kReset,           ///< failure or bad input: the estimator reset, a new session starts next frame
};
const char* vioStatusName(VioStatus status);

/// The estimator's output for one processed frame.
struct VioFrameResult {
  double t_stamp = 0.0;  ///< image header stamp as recorded [s]
  double t_state = 0.0;  ///< t_stamp - td used for this frame (the state's time)
  VioStatus status = VioStatus::kTracking;
  std::uint32_t session = 0;
  /// Body pose in the VIO frame at the recorded stamp t_stamp (the state at t_state moved to
  /// t_stamp with the velocity and rate: a few ms of motion).
  Eigen::Isometry3d T_odom_b_at_stamp = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_odom_b = Eigen::Isometry3d::Identity();  ///< body pose at t_state
  Eigen::Vector3d v_odom_b = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  double td = 0.0;
  bool keyframe = false;  ///< the previous frame was kept as a keyframe at this step
  int features_in_window = 0;
  int sonar_factors = 0;
  int pressure_factors = 0;
  /// Seabed gradient (dh/dx, dh/dy) under the newest frame in the VIO frame (zero for the
  /// horizontal seabed model); its height below the body is seabed_height - body z when set.
  Eigen::Vector2d seabed_slope = Eigen::Vector2d::Zero();
  std::optional<double> seabed_height;  ///< z of the newest sonar hit in the VIO frame [m]
  /// The newest frame's sonar beam hit on the seabed in the VIO frame, when it has a range.
  std::optional<Eigen::Vector3d> sonar_hit;
  double backend_ms = 0.0;  ///< wall time of this frame's optimisation and marginalisation
};

/// IMU-rate propagated state (for the node's high-rate odometry).
struct VioImuState {
  double t = 0.0;
  std::uint32_t session = 0;
  Eigen::Isometry3d T_odom_b = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v_odom_b = Eigen::Vector3d::Zero();
};

/// A seabed height measured by the sonar at one keyframe (gravity-aligned VIO frame).
struct SeabedFix {
  double height = 0.0;                              ///< z of the beam's seabed hit [m]
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();     ///< horizontal position of the keyframe [m]
  double t = 0.0;                                   ///< the keyframe's state time [s]
  Eigen::Vector2d slope = Eigen::Vector2d::Zero();  ///< seabed gradient there (local_plane model)
};

/// "rotation D deg, translation T m from the sequence YAML's; T_b_c = [16 numbers]": how an
/// estimated camera extrinsic differs from the calibration (log lines, summary.yaml).
std::string extrinsicChange(const Eigen::Isometry3d& yaml_T_b_c, const Eigen::Isometry3d& estimated_T_b_c);

class VioEstimator {
 public:
  /// Throws std::invalid_argument for unusable calibration (e.g. IMU noise not > 0).
  VioEstimator(const SequenceConfig& sequence, const EstimatorOptions& options,
               LoggerPtr logger = Logger::nullLogger());
  ~VioEstimator();

  /// IMU sample (body frame). Non-finite samples are dropped with a warning; a stamp going
  /// backwards resets the estimator; gaps longer than imu_max_gap_s reset it.
  void feedImu(const ImuSample& sample);
  /// Filtered sonar range: only accepted results with an estimate are used.
  void feedSonar(const SonarFilterResult& result);
  /// Pressure sample (sequences with a pressure sensor): converted to the port's depth with the
  /// YAML's calibration; spikes and non-finite values are dropped with a warning.
  void feedPressure(const PressureSample& sample);
  /// Tracked frame (the tracker runs before). `image` (optional) is kept for KeyframeData.
  void feedFrame(const TrackedFrame& frame, const cv::Mat& image = cv::Mat());

  /// Results of the frames processed since the last call, in order.
  std::vector<VioFrameResult> takeFrameResults();
  /// Keyframes confirmed since the last call (for the pose graph), in order.
  std::vector<KeyframeData> takeKeyframes();
  /// The latest state propagated with the IMU up to the newest sample (nullopt before init).
  std::optional<VioImuState> imuPropagatedState() const;

  std::uint32_t session() const { return session_; }
  /// Sessions dropped so far (failure, IMU gap, time going backwards, ...), whichever input
  /// triggered the reset.
  long resets() const { return resets_; }
  bool initialized() const { return !frames_.empty(); }
  double td() const { return td_[0]; }
  /// The camera-IMU extrinsic in use: the sequence YAML's, or its online estimate
  /// (EstimatorOptions::estimate_extrinsic).
  Eigen::Isometry3d extrinsicCamera() const;
  const EstimatorOptions& options() const { return options_; }
  /// Drops the window and starts a new session at the next frame.
  void reset(const std::string& why);

 private:
  struct Frame;
  struct Feature;

  void processPendingFrames();
  void processFrame(const TrackedFrame& frame, const cv::Mat& image);
  /// Completes a frame's result with `status` and the newest state: its pose moved to the
  /// recorded stamp, the seabed slope, the sonar hit and the seabed height under the vehicle.
  void completeResult(VioStatus status, VioFrameResult* result) const;
  bool initializeFirstFrame(const TrackedFrame& frame, const cv::Mat& image, double t_state);
  /// Sonar-free start: collects frames with parallax and runs the SfM + IMU alignment
  /// (VisualInertialInitializer); true once the window is built from its result.
  bool initializeVisualInertial(const TrackedFrame& frame, const cv::Mat& image, double t_state);
  std::unique_ptr<Frame> makeFrame(const TrackedFrame& frame, const cv::Mat& image, double t_state);
  void addObservations(Frame* frame, const TrackedFrame& tracked);
  double parallaxPx(const Frame& a, const Frame& b, int* common) const;
  std::optional<double> sonarRangeAt(double t) const;
  /// sonar_max_interpolation_gap_s, or 2.5 periods of the sequence's sonar if longer (a slow
  /// sonar: one lost sample is still interpolated over).
  double sonarInterpolationGapS() const;
  /// sonar_wait_s, or 1.5 periods of a sensor of `rate_hz` if longer: the range after a frame
  /// comes within one period, so the wait must cover one for online to equal offline.
  double rangeWaitS(double rate_hz) const;
  std::optional<double> pressureDepthAt(double t) const;
  bool usePressure() const { return options_.pressure.enabled && pressure_filter_ != nullptr; }
  bool slopedSeabed() const { return options_.use_sonar && options_.seabed.model == SeabedModel::kLocalPlane; }
  void initializeFeatureDepths();
  bool seabedDepth(const Feature& feature, double* lambda) const;
  bool triangulate(const Feature& feature, double* lambda) const;
  void optimize(VioFrameResult* result);
  /// Optimises only the newest frame's pose and speed-bias against the fixed rest of the window
  /// (EstimatorOptions::solve_window_every_frame = false, on steps that keep no keyframe).
  void optimizeNewest(VioFrameResult* result);
  /// Looks up the sonar range of window frames that had none when they arrived (the range may
  /// come after the image); warns (throttled) when a frame one step old still has none: a gap.
  void fillMissingSonarRanges();
  void removeOutliers();
  bool detectFailure(const Eigen::Vector3d& p_before, std::string* why) const;
  void marginalizeOldest();
  void dropSecondNewest();
  void reanchorFeaturesOf(const Frame* frame);
  void removeFeatureObservationsOf(const Frame* frame);
  void emitKeyframe(Frame& frame);
  void pruneImu();
  Eigen::Vector3d featureWorld(const Feature& feature) const;
  /// Sets every window observation's image velocity (the td correction's direction) to the one
  /// the current state predicts (docs/estimator.md, "Time offset td").
  void predictImageVelocities();
  /// Gyroscope reading at t (linear interpolation of the buffered samples; nearest at the ends).
  Eigen::Vector3d gyroAt(double t) const;
  static bool priorTouches(const MarginalizationPrior& prior, const Frame* frame);

  SequenceConfig sequence_;
  EstimatorOptions options_;
  LoggerPtr logger_;
  ImuNoiseParams noise_;
  Eigen::Vector3d g_l_;
  double focal_ = 1.0;
  /// The lens, for each observation's pixel-noise whitening (ReprojectionOptions::lens_weighting).
  CameraModel camera_;
  bool weigh_through_lens_ = false;
  double sonar_sigma_ = 0.05;
  /// The seabed height the sonar last measured, in this session's frame l, and where (x, y):
  /// carried through sonar outages (SonarDepthOptions::carry_seabed_through_outages).
  std::optional<SeabedFix> seabed_fix_;
  /// Refreshes seabed_fix_ from the newest window frame with a sonar range (current estimate).
  void updateSeabedFix();
  /// Features the solve ties to the carried seabed (they share its error: vio_window.h).
  int carriedFeatureCount(const vio_window::SeabedTies& seabed) const;
  /// The sonar hits that left the window and the relief learnt from them with the window's
  /// (SonarDepthOptions::learn_misfit); the estimate is kept through stretches without pairs.
  SeabedRelief seabed_relief_;
  std::optional<SeabedReliefEstimate> relief_;
  double last_relief_log_t_ = -1e300;
  /// How this solve (update_relief: it also re-learns the relief first) or this
  /// marginalisation ties features to the seabed; counts each frame's sonar-tied features.
  vio_window::SeabedTies seabedTies(bool sloped, bool update_relief);
  /// Sets each frame's sonar_features (the features tied to its hit: anchored there and not in
  /// `nearest_hit_ties`, or tied there by it); with_distances: also returns the horizontal
  /// distances of all sonar-tied features from their hits at the current estimate (only
  /// learning needs them).
  std::vector<double> countSonarFeatures(bool with_distances,
                                         const std::map<std::uint64_t, vio_window::HitTie>& nearest_hit_ties);
  /// The features whose nearest hit is not their anchor's but another window keyframe's, or one
  /// that left the window where the learnt relief sets their own factor's growth
  /// (SonarDepthOptions::tie_to_nearest_hit), at the current estimate.
  std::map<std::uint64_t, vio_window::HitTie> nearestHitTies(bool sloped) const;
  void updateSeabedRelief(const std::vector<double>& feature_distances, bool sloped);
  /// The seabed point frame f's sonar hit, at the current estimate (nullopt without a range).
  std::optional<SeabedSample> seabedSample(const Frame& f, bool sloped) const;

  std::vector<ImuSample> imu_;                   ///< recent IMU samples, strictly increasing
  std::deque<std::pair<double, double>> sonar_;  ///< (t, filtered range) of accepted results
  /// Pressure: the filter (null without a pressure sensor in the sequence), the accepted (t,
  /// depth) samples, the surface height in this session's frame l (a state, once initialised).
  std::unique_ptr<PressureDepthFilter> pressure_filter_;
  std::deque<std::pair<double, double>> pressure_;
  double surface_z_[1] = {0.0};
  bool surface_initialized_ = false;
  double pressure_sigma_ = 0.01;
  bool warned_above_surface_ = false;
  /// Sets the surface height from the first window frame with a depth, once per session.
  void initializeSurface();
  /// Pressure factors of the window frames with a depth (only the newest: the surface constant);
  /// returns how many.
  int addPressureFactors(ceres::Problem* problem, ceres::LossFunction* loss, bool newest_only);
  /// local_plane: every frame's gradient block, their random walk and the session's first prior.
  void addSeabedSlopeBlocks(ceres::Problem* problem);
  double slopeStepSigma(const Frame& a, const Frame& b) const;
  std::deque<std::pair<TrackedFrame, cv::Mat>> pending_;
  /// Frames collected for the visual-inertial initialisation (use_sonar: false), oldest first.
  struct InitCandidate {
    TrackedFrame frame;
    cv::Mat image;
    double t_state = 0.0;
  };
  std::deque<InitCandidate> vi_init_frames_;

  std::deque<std::unique_ptr<Frame>> frames_;  ///< the window, oldest first
  std::map<std::uint64_t, Feature> features_;
  double T_b_c_block_[7];
  double td_[1];
  /// Marginalisation priors on window states (usually one; a second one only lives until the
  /// states it shares with no other prior leave the window).
  std::vector<std::shared_ptr<const MarginalizationPrior>> priors_;
  std::uint32_t session_ = 0;
  long resets_ = 0;
  bool session_started_ = false;
  double last_good_tracking_t_ = 0.0;
  double last_frame_stamp_ = -1e300;
  double last_td_log_t_ = -1e300;         ///< stamp of the last td log line (estimate_td)
  double last_extrinsic_log_t_ = -1e300;  ///< stamp of the last extrinsic log line (estimate_extrinsic)

  std::vector<VioFrameResult> results_;
  std::vector<KeyframeData> keyframes_;
};

}  // namespace vims
