#pragma once
/// @file reprojection_factor.h
/// @brief Reprojection of a direct-depth feature from its anchor (first) keyframe i into keyframe k.
///
/// States: pose_i = T_l_bi, pose_k = T_l_bk, extrinsic T_b_c (usually held constant), the
/// feature's direct depth lambda (distance from the anchor camera centre, feature_observation.h)
/// and the camera-IMU time offset td. Measurements: the anchor observation (uv_i, velocity_i,
/// td_frame_i) and the target observation (uv_k, velocity_k, td_frame_k), undistorted and on the
/// normalised image plane.
///
///   f_ci = lambda b_i(td)                          b_i = unit bearing of uv_i + (td - td_i) vel_i
///   f_bi = R_bc f_ci + p_bc
///   f_l  = R_i f_bi + p_i
///   f_bk = R_k^T (f_l - p_k)
///   f_ck = R_bc^T (f_bk - p_bc) = (x, y, z)
///   r    = (x/z, y/z) - (uv_k + (td - td_k) vel_k)                       (2 residuals)
///
/// whitened by W / sigma_px, W = d pixel / d uv at the target observation, i.e. in units of the
/// pixel noise: W = diag(fx, fy) D(uv) through the lens (D = d distort / d uv; a fisheye's
/// normalised plane stretches a pixel's error by 1/cos^2(theta) radially, 4.9x at 63 deg off
/// axis), diag(fx, fy) for the pinhole's scaling (pixelFromNormalizedJacobian()).
///
/// Tangent Jacobians (pose tangent [dp, dtheta] with q' = q Exp(dtheta)); with
/// P = [1/z 0 -x/z^2; 0 1/z -y/z^2] and A = R_bc^T R_k^T:
///   dr/dp_i     = P A                      dr/dth_i = -P A R_i [f_bi]x
///   dr/dp_k     = -P A                     dr/dth_k = P R_bc^T [f_bk]x
///   dr/dp_bc    = P R_bc^T (R_k^T R_i - I) dr/dth_bc = P ([f_ck]x - A R_i R_bc [f_ci]x)
///   dr/dlambda  = P A R_i R_bc b_i
///   dr/dtd      = P A R_i R_bc lambda db_i/dtd - vel_k
/// Derivations: docs/factors.md, "Reprojection factor".

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

#include "vims_common/camera_model.h"
#include "vims_common/config_reader.h"
#include "vims_estimator/feature_observation.h"

namespace vims {

template <typename Options>
class OptionTable;

/// How a pixel sigma becomes the weight of a residual on the normalised plane (file comment).
enum class LensWeighting {
  kAuto,  ///< through the lens for the equidistant (fisheye) model, the pinhole's scaling for radtan
  kOn,    ///< through the lens for every model
  kOff,   ///< diag(fx, fy) for every model
};
std::string toString(LensWeighting weighting);

struct ReprojectionOptions {
  /// [px] Standard deviation of a tracked feature position in the image: KLT tracks to ~0.5-1 px
  /// and the motion blur of an AUV camera adds about as much; VINS-Mono uses the same 1.5 px.
  double pixel_sigma = 1.5;
  /// Whether that sigma is mapped onto the normalised plane through the lens's Jacobian at each
  /// observation. A fisheye (about 110 deg across) needs it: with diag(fx, fy) its edge features
  /// weigh 5-25x too much and a 1.5 px error there reads as 7 px to the outlier check. A radtan
  /// lens departs from its focal scaling by 10-25 % at the image corners; `auto` keeps the
  /// focal scaling there (docs/benchmarks.md, "Fisheye weighting").
  LensWeighting lens_weighting = LensWeighting::kAuto;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<ReprojectionOptions>& optionTable();

  /// Reads {pixel_sigma, lens_weighting}; unknown keys and bad values throw ConfigError naming the key.
  static ReprojectionOptions fromReader(const ConfigReader& reader);
  std::string toYaml() const;
};

/// True when `weighting` maps the pixel sigma through the lens of `model`.
bool weighsThroughLens(LensWeighting weighting, DistortionModel model);

/// W = d pixel / d uv at the undistorted normalised point `uv` (file comment): diag(fx, fy) times
/// the distortion's Jacobian through the lens, diag(fx, fy) otherwise. An observation's residual
/// is whitened by W / pixel_sigma, its error in pixels is |W r|.
Eigen::Matrix2d pixelFromNormalizedJacobian(const CameraModel& camera, const Eigen::Vector2d& uv, bool through_lens);

/// Tangent-space Jacobians of the unwhitened reprojection residual.
struct ReprojectionJacobians {
  Eigen::Matrix<double, 2, 6> d_pose_anchor;
  Eigen::Matrix<double, 2, 6> d_pose_target;
  Eigen::Matrix<double, 2, 6> d_extrinsic;
  Eigen::Vector2d d_lambda;
  Eigen::Vector2d d_td;
};

/// The unwhitened residual r (file comment). `depth_in_target` (optional) receives z, the
/// feature's depth in the target camera, which the caller can use to reject features behind it.
/// Jacobians are filled if `jacobians` is non-null.
Eigen::Vector2d reprojectionResidual(const FeatureObservation& anchor, const FeatureObservation& target,
                                     const Eigen::Isometry3d& T_l_bi, const Eigen::Isometry3d& T_l_bk,
                                     const Eigen::Isometry3d& T_b_c, double lambda, double td,
                                     ReprojectionJacobians* jacobians = nullptr, double* depth_in_target = nullptr);

/// Ceres wrapper: parameter blocks [pose_i (7), pose_k (7), T_b_c (7), lambda (1), td (1)].
/// Evaluate() returns false (Ceres rejects the step) when the feature would be at depth
/// z <= kMinDepth in the target camera, where the projection is undefined; the caller must only
/// add factors for features in front of both cameras at the initial estimate.
class ReprojectionFactor : public ceres::SizedCostFunction<2, 7, 7, 7, 1, 1> {
 public:
  /// [m] Depth below which the projection is treated as undefined (a division guard, far below
  /// any camera's near limit).
  static constexpr double kMinDepth = 1e-6;

  /// `sqrt_information` whitens the normalised-plane residual: pixelFromNormalizedJacobian() / pixel_sigma.
  ReprojectionFactor(const FeatureObservation& anchor, const FeatureObservation& target,
                     const Eigen::Matrix2d& sqrt_information);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  FeatureObservation anchor_;
  FeatureObservation target_;
  Eigen::Matrix2d sqrt_information_;
};

}  // namespace vims
