#pragma once
/// @file vio_window.h
/// @brief Private to vims_estimator_core: the sliding window's content (frames, features) and
/// the constants and helpers that the estimator's translation units share (vio_estimator.cpp:
/// input and frame processing; vio_feature_depths.cpp: depths; vio_window_solve.cpp: the solves;
/// vio_window_slide.cpp: marginalisation and dropping frames).

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "vims_estimator/factors/reprojection_factor.h"
#include "vims_estimator/factors/sonar_depth_factor.h"
#include "vims_estimator/factors/window_hit_factor.h"
#include "vims_estimator/state_blocks.h"
#include "vims_estimator/vio_estimator.h"

namespace vims {
namespace vio_window {

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

}  // namespace vio_window

// ---------------------------------------------------------------------------------------------
// Window content
// ---------------------------------------------------------------------------------------------

struct VioEstimator::Frame {
  struct Obs {
    FeatureObservation fo;
    Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
    /// d pixel / d uv here (pixelFromNormalizedJacobian): the residual's whitening is this over the
    /// pixel sigma, its error in pixels |pixel_from_uv r|.
    Eigen::Matrix2d pixel_from_uv = Eigen::Matrix2d::Zero();
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
  /// Seabed gradient (dh/dx, dh/dy) in frame l under this frame (seabed model local_plane).
  double slope[2] = {0.0, 0.0};
  /// Features anchored here with a sonar depth factor (VioEstimator::seabedTies counts them): they
  /// all err by this frame's hit's deviation from the plane (SonarDepthOptions::learn_misfit).
  int sonar_features = 0;
  /// Depth of the pressure port below the surface at t_state [m] (sequences with a pressure sensor).
  std::optional<double> depth;
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

namespace vio_window {

/// One residual block of the window, built identically for the solve and for marginalisation.
struct ResidualSpec {
  ceres::CostFunction* cost = nullptr;  ///< owned by whoever consumes the spec
  bool sonar = false;                   ///< Cauchy (sonar) or Huber (reprojection) loss
  std::vector<double*> blocks;
};

/// Linear interpolation of a time series (t, value) at t from the samples bracketing it within
/// `gap` seconds; without a bracketing pair, the nearest sample within gap / 2; else nullopt.
std::optional<double> interpolateSeries(const std::deque<std::pair<double, double>>& series, double t, double gap);

/// Solver settings of the window solves: a few dogleg iterations from the previous solution,
/// single-threaded (the offline runner's determinism), with the optional wall-clock cap.
inline ceres::Solver::Options windowSolverOptions(const EstimatorOptions& options,
                                                  ceres::LinearSolverType linear_solver) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = linear_solver;
  solver_options.trust_region_strategy_type = ceres::DOGLEG;
  solver_options.max_num_iterations = options.max_solver_iterations;
  if (options.max_solver_time_s > 0.0) solver_options.max_solver_time_in_seconds = options.max_solver_time_s;
  solver_options.num_threads = 1;
  solver_options.logging_type = ceres::SILENT;
  return solver_options;
}

/// A feature tied to a sonar hit nearer to it than its anchor's (SonarDepthOptions::
/// tie_to_nearest_hit): either another window keyframe's live hit (`window_frame`, its index in
/// the window: its pose, range and gradient are the window's, window_hit_factor.h), or one that
/// left the window (no index: the plane through it, its height and the gradient it had, constants). `distance` is the
/// feature's horizontal distance from it; `sharing` the number of features tied to the same kept
/// hit (they share its deviation from the plane, as an anchor's do; a window keyframe's count is
/// its Frame::sonar_features).
struct HitTie {
  std::optional<std::size_t> window_frame;
  SeabedPlane plane;
  double distance = 0.0;
  int sharing = 1;
};

/// How features are tied to the seabed: the sonar depth factor where the anchor keyframe has a
/// range, else (outage) a seabed height factor at the last measured height, if any.
struct SeabedTies {
  bool use_sonar = false;
  Eigen::Isometry3d T_b_s = Eigen::Isometry3d::Identity();
  double sonar_sigma = 0.05;
  const SonarDepthOptions* options = nullptr;
  const SeabedFix* carried = nullptr;  ///< the last measured seabed, null before the first range
  bool sloped = false;                 ///< local_plane: the sonar factor uses the anchor's seabed gradient block
  /// Features tied to the carried plane in this solve (carriedFeatureCount). Its error (one
  /// ping, extrapolated over metres of a seabed that is only locally a plane) is common to all of
  /// them, so each factor's variance is scaled by this count: together they weigh as the one
  /// measurement they share, not as that many independent ones.
  int carried_features = 1;
  /// The seabed's relief learnt from the sonar's hits (seabed_relief.h), nullopt until learnt or
  /// without learn_misfit: SonarDepthOptions::misfitPerM turns it into the factors' growth.
  std::optional<double> relief_per_m;
  /// Features tied to a hit nearer to them than their anchor's (HitTie).
  std::map<std::uint64_t, HitTie> nearest_hit_ties;
};

/// Whether `feature` would be tied to the carried seabed (its anchor has no range, a fix exists
/// within carry_max_distance_m): the count that SeabedTies::carried_features wants.
template <typename FrameT, typename FeatureT>
bool tiedToCarriedSeabed(const FeatureT& feature, const SeabedTies& seabed) {
  if (!seabed.use_sonar || !feature.sonar_ok || !feature.has_depth || seabed.carried == nullptr) return false;
  const FrameT* a = feature.anchor;
  if (a->sonar_range || !seabed.options->carry_seabed_through_outages) return false;
  const Eigen::Vector2d xy(a->pose[0], a->pose[1]);
  return (xy - seabed.carried->xy).norm() <= seabed.options->carry_max_distance_m;
}

/// Reprojection and sonar residual blocks of one feature at the current estimate.
template <typename FrameT, typename FeatureT>
void featureResiduals(FeatureT& feature, const std::deque<std::unique_ptr<FrameT>>& frames, double* T_b_c, double* td,
                      double pixel_sigma, const SeabedTies& seabed, bool apply_gate, std::vector<ResidualSpec>* out) {
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
    spec.cost = new ReprojectionFactor(anchor, it->second.fo, it->second.pixel_from_uv / pixel_sigma);
    spec.blocks = {a->pose, frame->pose, T_b_c, feature.lambda, td};
    out->push_back(spec);
  }
  if (out->size() == first) return;  // observed in the anchor only: no constraint
  if (!seabed.use_sonar || !feature.sonar_ok) return;
  const SonarDepthOptions& options = *seabed.options;
  const auto tie = seabed.nearest_hit_ties.find(feature.id);
  FrameT* j = nullptr;
  std::optional<SeabedPlane> tie_plane;
  double tie_sigma = 0.0;
  if (tie != seabed.nearest_hit_ties.end()) {
    const HitTie& hit = tie->second;
    j = hit.window_frame ? frames.at(*hit.window_frame).get() : nullptr;
    tie_sigma = SonarDepthOptions::sigmaAt(
        seabed.sonar_sigma, hit.distance, options.misfitPerM(seabed.relief_per_m, j ? j->sonar_features : hit.sharing));
    const Eigen::Vector2d slope_j =
        j && seabed.sloped ? Eigen::Vector2d(j->slope[0], j->slope[1]) : Eigen::Vector2d::Zero();
    tie_plane = j ? windowHitPlane(*j->sonar_range, seabed.T_b_s, j->T_l_b(), slope_j) : hit.plane;
    // A nearest hit the feature disagrees with (a rock under that beam or beside the feature) is
    // not a verdict on the feature: it keeps its anchor's hit, whose own gate judges it. Checked
    // in the solve and in marginalisation alike.
    if (!seabedHeightGate(anchor, *tie_plane, T_l_bi, T_bc, feature.lambda[0], td[0], tie_sigma, options).consistent)
      tie_plane.reset();
  }
  if (tie_plane) {
    const double sigma = tie_sigma;
    const SeabedPlane& plane = *tie_plane;
    ResidualSpec spec;
    spec.sonar = true;
    if (j == nullptr) {
      spec.cost = new SeabedHeightFactor(anchor, plane, sigma);
      spec.blocks = {a->pose, T_b_c, feature.lambda, td};
    } else if (seabed.sloped) {
      spec.cost = new SlopedWindowHitFactor(anchor, *j->sonar_range, seabed.T_b_s, sigma);
      spec.blocks = {a->pose, j->pose, T_b_c, feature.lambda, td, j->slope};
    } else {
      spec.cost = new WindowHitFactor(anchor, *j->sonar_range, seabed.T_b_s, sigma);
      spec.blocks = {a->pose, j->pose, T_b_c, feature.lambda, td};
    }
    out->push_back(spec);
    return;
  }
  if (a->sonar_range) {
    const double distance =
        sonarHitDistance(anchor, *a->sonar_range, seabed.T_b_s, T_l_bi, T_bc, feature.lambda[0], td[0]);
    const double sigma = SonarDepthOptions::sigmaAt(seabed.sonar_sigma, distance,
                                                    options.misfitPerM(seabed.relief_per_m, a->sonar_features));
    if (apply_gate) {
      const Eigen::Vector2d slope = seabed.sloped ? Eigen::Vector2d(a->slope[0], a->slope[1]) : Eigen::Vector2d::Zero();
      const SonarGateResult gate = sonarDepthGate(anchor, *a->sonar_range, seabed.T_b_s, T_l_bi, T_bc,
                                                  feature.lambda[0], td[0], sigma, options, slope);
      if (!gate.consistent) feature.sonar_ok = false;
    }
    if (feature.sonar_ok) {
      ResidualSpec spec;
      spec.sonar = true;
      if (seabed.sloped) {
        spec.cost = new SlopedSonarDepthFactor(anchor, *a->sonar_range, seabed.T_b_s, sigma);
        spec.blocks = {a->pose, T_b_c, feature.lambda, td, a->slope};
      } else {
        spec.cost = new SonarDepthFactor(anchor, *a->sonar_range, seabed.T_b_s, sigma);
        spec.blocks = {a->pose, T_b_c, feature.lambda, td};
      }
      out->push_back(spec);
    }
    return;
  }
  if (!tiedToCarriedSeabed<FrameT>(feature, seabed)) return;  // the same test carriedFeatureCount counts
  const SeabedFix& fix = *seabed.carried;
  const double distance = (T_l_bi.translation().head<2>() - fix.xy).norm();
  const double sigma = options.carriedSigma(seabed.sonar_sigma, distance);
  // The gate's verdict on a carried height is not kept in sonar_ok: once the sonar is back the
  // anchor's own range judges the feature afresh.
  const SeabedPlane plane{fix.height, fix.xy, seabed.sloped ? fix.slope : Eigen::Vector2d::Zero()};
  if (apply_gate && !seabedHeightGate(anchor, plane, T_l_bi, T_bc, feature.lambda[0], td[0], sigma, options).consistent)
    return;
  ResidualSpec spec;
  spec.cost = new SeabedHeightFactor(anchor, plane, sigma * std::sqrt(std::max(1, seabed.carried_features)));
  spec.sonar = true;
  spec.blocks = {a->pose, T_b_c, feature.lambda, td};
  out->push_back(spec);
}

}  // namespace vio_window
}  // namespace vims
