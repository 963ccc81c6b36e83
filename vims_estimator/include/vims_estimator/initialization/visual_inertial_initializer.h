#pragma once
/// @file visual_inertial_initializer.h
/// @brief VINS-Mono-style visual-inertial initialisation for the sonar-free mode: a monocular
/// structure-from-motion of a window of frames (up to scale), the gyroscope bias from the
/// visual rotations, and the linear alignment of the IMU preintegrations with the visual
/// trajectory for the frames' velocities, gravity and the metric scale, with gravity refined on
/// its 2-DoF tangent space. ROS-free. docs/estimator.md ("Visual-inertial initialisation")
/// gives the equations.
///
/// Excitation: with (near) constant velocity the IMU cannot tell the speed, so the scale and the
/// velocities trade off freely. The alignment therefore weights its equations with the
/// preintegration covariance and the SfM position noise, estimates the accelerometer bias under a
/// prior,
/// and reports kInsufficientExcitation when the resulting 1-sigma relative scale uncertainty
/// exceeds `max_relative_scale_std`, instead of returning a wrong scale.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "vims_common/config_reader.h"
#include "vims_estimator/imu_preintegration.h"

namespace vims {

template <typename Options>
class OptionTable;

struct VisualInertialInitOptions {
  /// Without the sonar, initialise the VIO with this SfM + IMU alignment (true), or from gravity
  /// alone with zero velocity and IMU-only scale (false). Off by default: on the tank sequences
  /// the vehicle barely accelerates, the alignment never passes the excitation test and the
  /// sonar-free VIO would produce no output at all (docs/estimator.md); the gravity start gives
  /// a trajectory with a drifting scale, the paper's "w/o sonar" ablation.
  bool enabled = false;
  /// Frames (keyframes chosen by parallax) in the initialisation window; VINS-Mono uses its
  /// whole 10-keyframe window plus the newest frame.
  int window_frames = 11;
  /// The SfM's reference pair (a frame and the newest) needs this many common features ...
  int min_relative_pose_features = 20;
  /// ... and this mean parallax [px] (VINS-Mono: 30 px at focal 460): below it the essential
  /// matrix and the triangulation are unreliable.
  double min_relative_pose_parallax_px = 30.0;
  /// [px] RANSAC threshold of the essential matrix (the tracker's noise is ~0.5-1.5 px).
  double ransac_threshold_px = 1.0;
  /// Minimum triangulated features after the bundle adjustment.
  int min_sfm_points = 30;
  /// [px] RMS reprojection error of the SfM bundle adjustment above which the SfM is rejected.
  double max_sfm_rms_px = 3.0;
  /// [m/s^2] The unconstrained gravity estimate must have the calibrated norm within this
  /// (VINS-Mono's check): a far-off norm means a wrong SfM or bad IMU data.
  double gravity_norm_tolerance = 1.0;
  /// Maximum 1-sigma relative uncertainty of the metric scale: above it the motion did not excite
  /// the accelerometer enough and the initialisation reports failure rather than a guess.
  double max_relative_scale_std = 0.02;
  /// [m/s^2] Prior sigma of the accelerometer bias estimated with the alignment: a MEMS turn-on
  /// bias. It is what makes a weak acceleration fail the excitation test (bias and scale trade off).
  double accel_bias_sigma = 0.05;
  /// [m] Noise of the SfM camera positions once scaled (enters every position equation).
  double sfm_position_sigma_m = 0.005;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<VisualInertialInitOptions>& optionTable();

  static VisualInertialInitOptions fromReader(const ConfigReader& reader);
  std::string toYaml() const;
};

enum class VisualInertialInitStatus {
  kSuccess,
  kTooFewFrames,            ///< fewer frames than needed, or a frame without preintegration
  kNoRelativePose,          ///< no frame pair with enough features and parallax (or E failed)
  kSfmFailed,               ///< PnP, triangulation or bundle adjustment failed
  kInsufficientExcitation,  ///< scale not observable: too little acceleration
  kAlignmentFailed,         ///< inconsistent solution (negative scale, wrong gravity norm)
};
const char* visualInertialInitStatusName(VisualInertialInitStatus status);

/// One frame of the initialisation window, oldest first.
struct InitFrame {
  double t = 0.0;  ///< the frame's state time [s]
  /// Undistorted normalised image coordinates of the features seen in this frame, by id.
  std::map<std::uint64_t, Eigen::Vector2d> observations;
  /// Preintegration from the previous window frame (null for the first frame). On success it is
  /// repropagated at the estimated gyroscope bias (accelerometer bias: its linearisation point).
  std::shared_ptr<ImuPreintegration> preintegration;
};

/// Up-to-scale structure from motion of the window, in the camera frame of the reference frame.
struct VisualSfmResult {
  bool ok = false;
  std::string message;
  int reference_frame = -1;               ///< the frame whose camera frame is c0
  std::vector<Eigen::Isometry3d> T_c0_c;  ///< camera poses (unit-ish translation scale)
  std::map<std::uint64_t, Eigen::Vector3d> points_c0;
  double rms_px = 0.0;
};

/// Monocular SfM: essential matrix between the earliest frame with enough parallax to the newest
/// (OpenCV, RANSAC), triangulation, PnP for the other frames, then a Ceres bundle adjustment.
VisualSfmResult solveVisualSfm(const std::vector<InitFrame>& frames, double focal_px,
                               const VisualInertialInitOptions& options);

struct VisualInertialInitResult {
  VisualInertialInitStatus status = VisualInertialInitStatus::kTooFewFrames;
  std::string message;
  double scale = 0.0;               ///< metres per SfM unit
  double scale_relative_std = 0.0;  ///< 1-sigma, from the weighted alignment
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
  /// Accelerometer bias estimated with the alignment (prior N(0, accel_bias_sigma^2)).
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  /// Gravity-aligned VIO frame (z up, gravity [0 0 -g]), origin and yaw of the first body pose.
  std::vector<Eigen::Isometry3d> T_w_b;
  std::vector<Eigen::Vector3d> v_w_b;
  std::map<std::uint64_t, Eigen::Vector3d> points_w;
  bool ok() const { return status == VisualInertialInitStatus::kSuccess; }
};

class VisualInertialInitializer {
 public:
  /// T_b_c: camera extrinsic; gravity: |g| [m/s^2]; focal_px: mean focal length (pixel units of
  /// the thresholds).
  VisualInertialInitializer(const Eigen::Isometry3d& T_b_c, double gravity, double focal_px,
                            const VisualInertialInitOptions& options);

  /// Runs SfM, gyroscope bias and alignment on the window. Never throws on bad data: every
  /// failure is a status with a message.
  VisualInertialInitResult initialize(std::vector<InitFrame>& frames) const;

  /// Gyroscope bias from the SfM body rotations R_c0_b (one Gauss-Newton step per call, on the
  /// preintegrations' gamma and their bias Jacobians). Exposed for tests.
  static Eigen::Vector3d solveGyroBias(const std::vector<InitFrame>& frames,
                                       const std::vector<Eigen::Quaterniond>& q_c0_b);

 private:
  Eigen::Isometry3d T_b_c_;
  double gravity_;
  double focal_;
  VisualInertialInitOptions options_;
};

}  // namespace vims
