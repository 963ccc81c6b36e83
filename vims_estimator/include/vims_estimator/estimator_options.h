#pragma once
/// @file estimator_options.h
/// @brief Options of the sliding-window visual-inertial-sonar estimator (VioEstimator), read from
/// the `estimator` section of the system configuration. Every default carries its reason;
/// calibration (extrinsics, intrinsics, IMU and sonar noise) never lives here: it comes from the
/// sequence YAML. docs/estimator.md lists all keys.

#include <string>

#include "vims_common/config_reader.h"
#include "vims_estimator/factor_options.h"
#include "vims_estimator/initialization/visual_inertial_initializer.h"
#include "vims_estimator/seabed_options.h"

namespace vims {

template <typename Options>
class OptionTable;

struct EstimatorOptions {
  // ---- window and keyframes ----
  /// Keyframes in the sliding window (plus the newest frame). VINS-Mono's 10: at 10 Hz and the
  /// 10 px parallax rule this spans a few seconds of AUV motion, enough for the IMU to see gravity
  /// and biases, while the dense Schur solve stays at a few ms.
  int window_size = 10;
  /// [px] Mean parallax (on the undistorted plane, times the mean focal length) of the features
  /// common to the two newest frames above which the second newest becomes a keyframe. VINS-Mono's
  /// 10 px: below it, triangulation from the pair adds little and the frame is only IMU payload.
  double keyframe_parallax_px = 10.0;
  /// A frame whose tracks into its predecessor fall below this count is kept as a keyframe
  /// whatever its parallax (VINS-Mono's 20): the scene is being replaced and the window must keep
  /// the frames that still share features.
  int keyframe_min_tracked = 20;

  // ---- solver ----
  /// Dogleg iterations per frame: the window starts from the previous solution, so a few
  /// iterations converge. Measured on tank750: 4 iterations give the same ATE as VINS-Mono's 8
  /// (0.115 % of the distance) with a quarter less back-end time.
  int max_solver_iterations = 4;
  /// [s] Wall-clock cap of one solve; 0.04 s keeps 10 Hz with margin on an embedded CPU. Set 0 to
  /// disable (the offline runner's determinism needs a bound on iterations only: see docs).
  double max_solver_time_s = 0.0;
  /// false: the whole window is optimised only on the steps that keep a keyframe (about one
  /// frame in five); on the other steps (the second newest frame is about to be dropped, its
  /// visual factors with it) only the newest frame's pose and speed-bias are optimised against
  /// the fixed window: its IMU factor from the previous frame and its reprojections of the
  /// landmarks with depth. The keyframes get the same full solves as before the drop, and the
  /// per-frame cost falls several fold (docs/estimator.md, "Cost"). true: every frame optimises
  /// the whole window (VINS-Mono).
  bool solve_window_every_frame = false;
  /// Huber scale of the reprojection factors in whitened units (pixel sigmas): residuals beyond
  /// one sigma grow linearly, so KLT drifts and mismatches cannot dominate.
  double reprojection_loss_scale = 1.0;
  /// Cauchy scale of the sonar depth factors in whitened units: a feature on a rock that slips
  /// through the gate has a bounded pull.
  double sonar_loss_scale = 1.0;

  // ---- features ----
  /// [m] Bounds of a plausible feature distance from its anchor camera: below 0.1 m is inside the
  /// housing; above 30 m nothing is visible under water (light attenuation).
  double min_feature_depth_m = 0.1;
  double max_feature_depth_m = 30.0;
  /// [deg] Minimum angle between the rays of the two farthest observations for triangulating a
  /// feature without the sonar: below ~1 deg the depth is unreliable.
  double triangulation_min_angle_deg = 1.0;
  /// [px] Features whose reprojection error exceeds this after a solve are removed (3 pixel
  /// sigmas of the default 1.5 px noise, with some allowance for the first solves).
  double outlier_reprojection_px = 5.0;

  // ---- sonar ----
  /// Use the sonar depth factors and the seabed-plane feature initialisation. false gives plain
  /// visual-inertial odometry (the paper's "w/o sonar" ablation).
  bool use_sonar = true;
  /// [s] The filtered range is interpolated to a frame time only from samples within this time of
  /// it (at the contract's 10 Hz, 0.25 s tolerates one missing sample; a slower sonar gets 2.5 of
  /// its periods, VioEstimator::sonarInterpolationGapS).
  double sonar_max_interpolation_gap_s = 0.25;
  /// [s] A frame waits for a filtered range at or after its time until the IMU is this far past
  /// it. The filtered ranges come one node later than the images on the AUV (the sonar filter
  /// node), so without the wait a frame took the previous range there and the interpolated one
  /// offline; with it both runs give every frame the same range. A sonar dropout delays each
  /// frame's processing by this much IMU time, no more. 0 = no wait.
  double sonar_wait_s = 0.2;
  /// [m] Floor on the range noise used for the factor (the sequence's range_noise_std may be 0
  /// for ideal simulations; 1 cm is the resolution of a typical altimeter).
  double sonar_min_range_std_m = 0.01;

  // ---- time offset ----
  /// Estimate the camera-IMU time offset td online (t_stamp = t_exposure + td). It recovers a
  /// simulated 30 ms delay within 3 ms and costs no accuracy without a delay (tank750 seed 1:
  /// 0.040 % either way; docs/estimator.md). Off by default because the contract's sequences
  /// (and the simulator unless --camera-delay) stamp images at exposure; turn it on for a real
  /// camera, whose stamps usually lag the IMU.
  bool estimate_td = false;
  /// [s] Initial td (e.g. a calibrated value).
  double td_initial_s = 0.0;
  /// [s] td is bounded to [-max_abs_td_s, max_abs_td_s]: beyond 0.2 s the first-order image-plane
  /// correction (uv + td vel) is no longer valid at AUV rotation rates.
  double max_abs_td_s = 0.2;
  /// [px/s] td is held constant in a solve unless the mean image speed of the window's tracked
  /// features exceeds this: td is only observable through image motion. With the flattened
  /// tracker (docs/frontends.md) td on tank60 / tank_td30 (0 / 30 ms delay) is -1.6 / +28.4 ms
  /// at 5 and 10 px/s, -1.8 / +27.4 ms at 20, -1.5 / +17.4 ms at 40 (fewer windows inform td).
  double td_min_image_speed_px_s = 10.0;

  // ---- camera-IMU extrinsic ----
  /// Refine the camera-IMU extrinsic T_b_c online (as VINS-Mono's estimate_extrinsic): it is a
  /// state of every window solve, with a prior at the sequence YAML's value of these sigmas, and
  /// its information is carried in the marginalisation prior. The estimate is logged every 30 s
  /// and written to summary.yaml (vio.T_b_c and its difference from the YAML's).
  bool estimate_extrinsic = false;
  double extrinsic_prior_rotation_rad = 2.0 * M_PI / 180.0;  ///< key extrinsic_prior_rotation_deg
  double extrinsic_prior_translation_m = 0.03;

  // ---- initialisation ----
  /// [s] Accelerometer averaging window for gravity at initialisation (before the first frame):
  /// 1 s averages the accelerometer white noise down by sqrt(200) at 200 Hz.
  double init_gravity_window_s = 1.0;
  /// [rad/s] If the gyro standard deviation over that window is below this, the vehicle is taken
  /// as static: its mean rate becomes the initial gyro bias and the initial velocity is zero.
  double init_static_gyro_std = 0.01;
  /// [m/s^2] Same test on the accelerometer norm.
  double init_static_accel_std = 0.05;
  /// Prior sigmas on the first state [m/s, m/s^2, rad/s]: they keep the first solves well-posed
  /// while the IMU has not yet excited the biases (about the size of an AUV's speed and of MEMS
  /// turn-on biases).
  double init_velocity_sigma = 0.2;
  double init_accel_bias_sigma = 0.1;
  double init_gyro_bias_sigma = 0.01;

  // ---- bad input and failure detection ----
  /// [s] IMU gaps up to this are integrated across (mid-point over the gap); longer gaps reset
  /// the estimator (the preintegration over them is meaningless). 1 s bridges a driver dropout of
  /// half a second (a gap of 0.5 s arrives as a 0.505 s step between samples): the AUV turns
  /// < 10 deg/s and barely accelerates, so the mid-point over 1 s stays within the IMU's noise
  /// far better than a reset, which loses the motion.
  double imu_max_gap_s = 1.0;
  /// [s] Frames are held until the IMU covers their time; after this much image-ahead-of-IMU lag
  /// a frame is dropped.
  double max_frame_wait_s = 1.0;
  /// Failure thresholds (VINS-Mono's values for the biases and the jump; an AUV never moves
  /// 2 m in one frame period).
  double failure_max_accel_bias = 2.5;  ///< [m/s^2]
  double failure_max_gyro_bias = 1.0;   ///< [rad/s]
  double failure_max_position_jump_m = 2.0;
  double failure_max_velocity = 5.0;  ///< [m/s] far above any AUV speed
  /// Fewer tracked features than this for longer than failure_lost_tracking_s: re-initialise.
  /// Until then the state is propagated by the IMU (frames without features are not added) and
  /// the first frame with features again is linked to the window by the preintegration across
  /// the outage. 10 s: a camera blackout of several seconds (turbidity, a strobe failure) keeps
  /// the odometry continuous; IMU-only drift over 10 s with estimated biases is decimetres, while
  /// a reset loses the whole motion of the outage.
  int failure_min_tracked = 8;
  double failure_lost_tracking_s = 10.0;

  FactorOptions factors;
  /// The seabed under the sonar (section `seabed`, seabed_options.h): horizontal or a local plane.
  SeabedModelOptions seabed;
  /// The pressure depth factor (section `pressure`), used when the sequence has the sensor.
  PressureOptions pressure;
  /// Sonar-free initialisation (use_sonar: false): SfM + IMU alignment (section
  /// `visual_inertial_init`, visual_inertial_initializer.h).
  VisualInertialInitOptions visual_inertial_init;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<EstimatorOptions>& optionTable();

  /// Unknown keys and out-of-range values throw ConfigError naming the key.
  static EstimatorOptions fromReader(const ConfigReader& reader);
  std::string toYaml() const;
};

}  // namespace vims
