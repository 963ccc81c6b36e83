#pragma once
/// @file sonar_depth_factor.h
/// @brief The sonar depth factor (the paper's contribution): a feature first seen in keyframe k
/// lies at the height of the flat seabed point that keyframe k's sonar beam hits.
///
/// States: pose_k = T_l_bk (the feature's anchor keyframe), extrinsic T_b_c, the feature's direct
/// depth lambda, and the time offset td (it moves the anchor bearing, feature_observation.h).
/// Constants: the sonar extrinsic T_b_s (from the sequence YAML, never estimated), the anchor
/// observation and the filtered sonar range d[k] interpolated to keyframe k's state time.
///
///   seabed point  s_l = T_l_bk T_b_s [0 0 d]^T  = p_k + R_k s_b,  s_b = p_bs + d R_bs e_z
///   feature       f_l = T_l_bk T_b_c (lambda b) = p_k + R_k f_b,  f_b = p_bc + lambda R_bc b
///   r = (s_l)_z - (f_l)_z = e_z^T R_k (s_b - f_b)                              (1 residual)
///
/// Both points hang off the same body pose, so p_k cancels: the factor constrains lambda through
/// the attitude (roll, pitch) of keyframe k only; dr/dp_k = 0. The VIO frame l is gravity aligned
/// (z up), so (.)_z is height and the flat-bottom assumption is "equal heights".
///
/// Tangent Jacobians (q' = q Exp(dtheta)):
///   dr/dp_k = 0                      dr/dth_k  = -e_z^T R_k [s_b - f_b]x
///   dr/dp_bc = -e_z^T R_k            dr/dth_bc = e_z^T R_k R_bc [lambda b]x
///   dr/dlambda = -e_z^T R_k R_bc b   dr/dtd    = -lambda e_z^T R_k R_bc db/dtd
///
/// Noise: sigma = sqrt(sigma_range^2 + sigma_flatness^2 + (m D)^2): the range noise of the filtered
/// sonar depth, the seabed's deviation from a plane at the beam spot, and a misfit growing with
/// the horizontal distance D between the feature and the hit (SonarDepthOptions::misfit_per_m:
/// a feature next to the spot sits on the hit's own bump, one metres away does not, and the
/// features of one keyframe share those bumps rather than err independently); D is taken at the
/// estimate when the factor is built, so sigma is a constant of the solve. The factor returns
/// r / sigma. It is meant to be used with a robust loss (Huber or Cauchy, chosen
/// by the caller) and after sonarDepthGate() has removed features off the seabed plane.
///
/// Seabed height factor (sonar outages): without a range at keyframe k, the last seabed height
/// h measured by the sonar (a constant in the gravity-aligned frame l) stands in for s_l:
///
///   r = h - (f_l)_z = h - p_k,z - e_z^T R_k f_b                                 (1 residual)
///
///   dr/dp_k = -e_z^T                 dr/dth_k  = e_z^T R_k [f_b]x
///   (extrinsic, lambda, td: as the sonar depth factor, whose s_b does not depend on them)
///
/// Unlike the sonar factor it depends on p_k: it ties the feature to an absolute height, so with
/// the vehicle's height from the IMU-propagated window it keeps the scale that the sonar gave
/// before the outage. sigma = sqrt(sigma_sonar^2 + (slope_std * D)^2) grows with the horizontal
/// distance D from where h was measured (the seabed is locally, not globally, flat).
///
/// Local seabed plane (seabed model `local_plane`, docs/factors.md 5c): the seabed under keyframe
/// k is a plane of gradient g = (dh/dx, dh/dy) in frame l, normal n = (-g_x, -g_y, 1). The
/// feature lies on the plane through the beam's hit s_l, so the vertical distance between the
/// plane and the feature at the feature's horizontal position is
///
///   r = (s_l)_z + g . ((f_l)_xy - (s_l)_xy) - (f_l)_z = n^T (s_l - f_l) = n^T R_k (s_b - f_b)
///
/// p_k still cancels; every Jacobian above holds with e_z replaced by n, and
///   dr/dg = ((f_l - s_l)_x, (f_l - s_l)_y) = -(R_k (s_b - f_b))_xy.
/// g = 0 is the horizontal plane of the paper. The carried height generalises in the same way:
/// r = h + g . ((f_l)_xy - xy_h) - (f_l)_z with the plane (h, xy_h, g) of the last fix (constant).

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "vims_common/config_reader.h"
#include "vims_estimator/feature_observation.h"

namespace vims {

template <typename Options>
class OptionTable;

struct SonarDepthOptions {
  /// [m] Deviation of the seabed from the plane at the beam spot: a tank floor is flat to a few
  /// centimetres, sand ripples are 2-5 cm high (the growth with distance is misfit_per_m).
  double flatness_std = 0.05;
  /// Gate on the whitened squared residual r^2/sigma^2: the 99 % quantile of chi-square with one
  /// degree of freedom, so a consistent feature is dropped 1 % of the time.
  double gate_chi2 = 6.635;
  /// [m/m] Growth of the factor's standard deviation with the horizontal distance D between the
  /// feature and the beam's hit: relief a metre or a few across (hummocks, hollows, boulders
  /// half-buried) that no plane follows. Its features sit on the same bumps, so their errors are
  /// shared, not independent, and the growth also keeps the many distant features of a keyframe
  /// from outvoting the few next to the spot, which see what the sonar saw. 0.3 (30 cm at 1 m)
  /// leaves the features within ~0.2 m of the spot at full weight; on smooth seabeds it is as good
  /// as 0 or better (docs/benchmarks.md, Terrain, measures 0, 0.1, 0.3 and 1.0). With
  /// learn_misfit it is the floor of the learnt growth. 0 and learn_misfit false: every feature
  /// as close as the hit (the paper's weighting).
  double misfit_per_m = 0.3;
  /// Learn the growth from the seabed (seabed_relief.h, docs/factors.md 5e): the relief m that
  /// pairs of sonar hits show at the features' distances, times sqrt((N + 1) / 2) for the N
  /// sonar-tied features of the anchor keyframe, which all err by the same hit's deviation from
  /// the plane; misfit_per_m where that is less, or until enough pairs are seen. A rough seabed
  /// weighs its distant features down by what its roughness is, wherever the vehicle is.
  bool learn_misfit = true;
  /// Sonar hits kept after their keyframe left the window to learn the relief from: 100 hits
  /// are some 10-30 m of track at survey speed, enough pairs for a median, short enough for the
  /// VIO's drift (millimetres) not to matter.
  int misfit_history_hits = 100;
  /// Pairs of hits at the features' distances needed before the learnt value replaces
  /// misfit_per_m (a median of fewer scatters by more than the relief).
  int misfit_min_pairs = 200;
  /// Tie a feature to the sonar hit nearest to it horizontally instead of its anchor's, where
  /// that is nearer (docs/factors.md 5f, 5g). The vehicle flies over much of what its camera
  /// sees, so the seabed under a feature is often measured centimetres from it a few seconds
  /// before or after, where the anchor's hit is a metre or more away, and the nearer the hit the
  /// less the seabed between them (relief, or a slope the model gets wrong) matters. Candidates:
  /// the other window keyframes' hits (both poses states of the window, window_hit_factor.h),
  /// and, where the learnt relief sets the feature's own factor's growth (above misfit_per_m;
  /// needs learn_misfit), the misfit_history_hits kept hits, held at the height and gradient they
  /// had when their keyframe left the window (on a seabed the sonar finds smooth a kept hit gains
  /// nothing and costs its stale pose). A nearest hit the feature disagrees with (the gate) leaves
  /// it on its anchor's. false: the anchor's hit only (the paper).
  bool tie_to_nearest_hit = true;
  /// [m] Hard gate on |r| independent of the noise model: a feature more than this above or below
  /// the sonar seabed is on a rock, a structure or a wall whatever sigma says.
  double gate_max_height_difference = 0.5;

  /// Sonar outages: features anchored in keyframes without a range get a seabed height factor
  /// (file comment) at the last measured seabed height while within carry_max_distance_m of it.
  bool carry_seabed_through_outages = true;
  /// [m/m] Growth of the carried height's standard deviation with horizontal distance: a 5 %
  /// slope is a gentle seabed; a flat tank floor is 0 (the prior is then conservative).
  double carry_slope_std = 0.05;
  /// [m] Beyond this horizontal distance from the last sonar fix the carried height is dropped.
  double carry_max_distance_m = 10.0;

  /// sqrt(range_std^2 + flatness_std^2).
  double sigma(double range_std) const;
  /// Standard deviation of the sonar depth factor of a feature `distance_m` from the beam's hit:
  /// sqrt(sonar_sigma^2 + (misfit * distance_m)^2), sonar_sigma = sigma(range_std), misfit from
  /// misfitPerM().
  static double sigmaAt(double sonar_sigma, double distance_m, double misfit);
  /// The growth of sigma per metre: misfit_per_m without a learnt relief (or with learn_misfit
  /// false), else max(misfit_per_m, relief_per_m * sqrt((anchor_features + 1) / 2)).
  double misfitPerM(const std::optional<double>& relief_per_m, int anchor_features) const;
  /// Standard deviation of the carried seabed height at horizontal distance `distance_m` from
  /// the fix: sqrt(sonar_sigma^2 + (carry_slope_std * distance_m)^2).
  double carriedSigma(double sonar_sigma, double distance_m) const;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<SonarDepthOptions>& optionTable();

  /// Reads {flatness_std, misfit_per_m, learn_misfit, misfit_history_hits, misfit_min_pairs,
  /// gate_chi2, gate_max_height_difference,
  /// carry_seabed_through_outages, carry_slope_std, carry_max_distance_m}; unknown keys, negative
  /// flatness_std, misfit_per_m or carry_slope_std and non-positive gates or distance throw
  /// ConfigError naming the key.
  static SonarDepthOptions fromReader(const ConfigReader& reader);
  std::string toYaml() const;
};

/// Tangent-space Jacobians of the unwhitened sonar depth (or seabed height) residual.
struct SonarDepthJacobians {
  Eigen::Matrix<double, 1, 6> d_pose;  ///< sonar depth: zero in the position columns (p_k cancels)
  Eigen::Matrix<double, 1, 6> d_extrinsic;
  double d_lambda = 0.0;
  double d_td = 0.0;
  Eigen::Matrix<double, 1, 2> d_slope = Eigen::Matrix<double, 1, 2>::Zero();  ///< w.r.t. the plane's gradient
};

/// A seabed plane in frame l known at one point: height `height` at horizontal position `xy`,
/// gradient `slope` (dh/dx, dh/dy). slope = 0 is the horizontal seabed.
struct SeabedPlane {
  double height = 0.0;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
  Eigen::Vector2d slope = Eigen::Vector2d::Zero();
  double heightAt(const Eigen::Vector2d& at) const { return height + slope.dot(at - xy); }
};

/// The beam's seabed hit s_b = p_bs + d R_bs e_z in the body frame, for slant range d [m].
Eigen::Vector3d sonarHitInBody(double range, const Eigen::Isometry3d& T_b_s);

/// The plane's normal n = (-g_x, -g_y, 1) as seen from the body: n^T R_l_b (exactly the third row
/// of R_l_b for g = 0, so the horizontal model's numbers do not depend on this generalisation).
Eigen::RowVector3d seabedNormalInBody(const Eigen::Vector2d& slope, const Eigen::Matrix3d& R_l_b);

/// The unwhitened residual r = n^T (s_l - f_l) (file comment; slope 0: (s_l)_z - (f_l)_z);
/// Jacobians if non-null (d_slope included).
double sonarDepthResidual(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s,
                          const Eigen::Isometry3d& T_l_bk, const Eigen::Isometry3d& T_b_c, double lambda, double td,
                          SonarDepthJacobians* jacobians = nullptr,
                          const Eigen::Vector2d& slope = Eigen::Vector2d::Zero());

/// The feature's position f_l = T_l_bk T_b_c (lambda b) in frame l.
Eigen::Vector3d featureInL(const FeatureObservation& anchor, const Eigen::Isometry3d& T_l_bk,
                           const Eigen::Isometry3d& T_b_c, double lambda, double td);

/// Horizontal distance D = |(f_l - s_l)_xy| between the feature and the beam's hit [m].
double sonarHitDistance(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s,
                        const Eigen::Isometry3d& T_l_bk, const Eigen::Isometry3d& T_b_c, double lambda, double td);

/// The unwhitened seabed height residual r = plane.heightAt((f_l)_xy) - (f_l)_z (file comment);
/// Jacobians if non-null. The plane is a constant (the last sonar fix).
double seabedHeightResidual(const FeatureObservation& anchor, const SeabedPlane& plane, const Eigen::Isometry3d& T_l_bk,
                            const Eigen::Isometry3d& T_b_c, double lambda, double td,
                            SonarDepthJacobians* jacobians = nullptr);

/// Result of the flat-bottom consistency gate.
struct SonarGateResult {
  double height_difference = 0.0;  ///< r = seabed height - feature height [m]
  double chi2 = 0.0;               ///< r^2 / sigma^2
  bool consistent = true;          ///< false: the caller drops the feature's sonar factor
};

/// Flat-bottom gate: evaluates r at the current estimate and flags the feature inconsistent when
/// chi2 > options.gate_chi2 or |r| > options.gate_max_height_difference (or r is not finite).
SonarGateResult sonarDepthGate(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s,
                               const Eigen::Isometry3d& T_l_bk, const Eigen::Isometry3d& T_b_c, double lambda,
                               double td, double sigma, const SonarDepthOptions& options,
                               const Eigen::Vector2d& slope = Eigen::Vector2d::Zero());

/// The same gate on a seabed height residual (a carried plane and its carriedSigma()).
SonarGateResult seabedHeightGate(const FeatureObservation& anchor, const SeabedPlane& plane,
                                 const Eigen::Isometry3d& T_l_bk, const Eigen::Isometry3d& T_b_c, double lambda,
                                 double td, double sigma, const SonarDepthOptions& options);

/// What a sonar depth factor measures, shared by the level and the sloped factor: the anchor
/// observation, the filtered range d[k], the sonar extrinsic and 1/sigma. Throws
/// std::invalid_argument (naming `factor`) if range is not finite and > 0 or sigma is not > 0.
struct SonarHitMeasurement {
  SonarHitMeasurement(const char* factor, const FeatureObservation& anchor, double range,
                      const Eigen::Isometry3d& T_b_s, double sigma);
  /// Writes r / sigma and the whitened Jacobians of blocks [pose_k, T_b_c, lambda, td] (and of
  /// the gradient, block 4, when `slope` is given).
  bool evaluate(double const* const* parameters, const Eigen::Vector2d* slope, double* residuals,
                double** jacobians) const;

  FeatureObservation anchor;
  double range;
  Eigen::Isometry3d T_b_s;
  double inv_sigma;
};

/// Ceres wrapper: parameter blocks [pose_k (7), T_b_c (7), lambda (1), td (1)]; returns r / sigma.
class SonarDepthFactor : public ceres::SizedCostFunction<1, 7, 7, 1, 1> {
 public:
  /// `range` is the filtered sonar range d[k] at keyframe k's state time [m]; `sigma` the total
  /// standard deviation (SonarDepthOptions::sigma). Throws std::invalid_argument if range is not
  /// finite and > 0 or sigma is not > 0.
  SonarDepthFactor(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s, double sigma);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  SonarHitMeasurement hit_;
};

/// The sonar depth factor on a local seabed plane whose gradient is a state (seabed model
/// `local_plane`): parameter blocks [pose_k (7), T_b_c (7), lambda (1), td (1), slope_k (2)];
/// returns r / sigma with r = n^T (s_l - f_l). Same argument checks as SonarDepthFactor.
class SlopedSonarDepthFactor : public ceres::SizedCostFunction<1, 7, 7, 1, 1, 2> {
 public:
  SlopedSonarDepthFactor(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s, double sigma);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  SonarHitMeasurement hit_;
};

/// Ceres wrapper of the seabed height residual: parameter blocks [pose_k (7), T_b_c (7),
/// lambda (1), td (1)]; returns r / sigma. Throws std::invalid_argument if the plane is not
/// finite or sigma is not > 0.
class SeabedHeightFactor : public ceres::SizedCostFunction<1, 7, 7, 1, 1> {
 public:
  SeabedHeightFactor(const FeatureObservation& anchor, const SeabedPlane& plane, double sigma);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  FeatureObservation anchor_;
  SeabedPlane plane_;
  double inv_sigma_;
};

}  // namespace vims
