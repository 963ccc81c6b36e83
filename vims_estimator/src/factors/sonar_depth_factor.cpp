#include "vims_estimator/factors/sonar_depth_factor.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include "vims_common/option_table.h"
#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

double SonarDepthOptions::sigma(double range_std) const {
  return std::sqrt(range_std * range_std + flatness_std * flatness_std);
}

double SonarDepthOptions::sigmaAt(double sonar_sigma, double distance_m, double misfit) {
  return std::hypot(sonar_sigma, misfit * distance_m);
}

double SonarDepthOptions::misfitPerM(const std::optional<double>& relief_per_m, int anchor_features) const {
  if (!learn_misfit || !relief_per_m) return misfit_per_m;
  return std::max(misfit_per_m, *relief_per_m * std::sqrt(0.5 * (std::max(anchor_features, 0) + 1)));
}

double SonarDepthOptions::carriedSigma(double sonar_sigma, double distance_m) const {
  return std::hypot(sonar_sigma, carry_slope_std * distance_m);
}

const OptionTable<SonarDepthOptions>& SonarDepthOptions::optionTable() {
  using O = SonarDepthOptions;
  static const auto table =
      OptionTable<O>()
          .number("flatness_std", &O::flatness_std, Bounds::nonNegative())
          .number("misfit_per_m", &O::misfit_per_m, Bounds::nonNegative())
          .flag("learn_misfit", &O::learn_misfit)
          .integer("misfit_history_hits", &O::misfit_history_hits, Bounds::positive())
          .integer("misfit_min_pairs", &O::misfit_min_pairs, Bounds::positive())
          .flag("tie_to_nearest_hit", &O::tie_to_nearest_hit)
          .number("gate_chi2", &O::gate_chi2, Bounds::positive())
          .number("gate_max_height_difference", &O::gate_max_height_difference, Bounds::positive())
          .flag("carry_seabed_through_outages", &O::carry_seabed_through_outages)
          .number("carry_slope_std", &O::carry_slope_std, Bounds::nonNegative())
          .number("carry_max_distance_m", &O::carry_max_distance_m, Bounds::positive());
  return table;
}

SonarDepthOptions SonarDepthOptions::fromReader(const ConfigReader& reader) {
  return readOptions<SonarDepthOptions>(reader);
}

std::string SonarDepthOptions::toYaml() const { return optionTable().toYaml(*this); }

namespace {
/// The feature f_b = p_bc + lambda R_bc b in the body frame of its anchor, and the Jacobian
/// columns of -n^T f_l = -n^T R_k f_b that the sonar depth and seabed height residuals share
/// (extrinsic, lambda, td); `up_in_b` = n^T R_k (seabedNormalInBody; e_z^T R_k for a level seabed).
Eigen::Vector3d featureInBody(const FeatureObservation& anchor, const Eigen::Isometry3d& T_b_c, double lambda,
                              double td, const Eigen::RowVector3d& up_in_b, SonarDepthJacobians* J) {
  const Eigen::Matrix3d R_bc = T_b_c.linear();
  Eigen::Vector3d db_dtd;
  const Eigen::Vector3d b = unitBearing(anchor, td, J ? &db_dtd : nullptr);
  if (J != nullptr) {
    J->d_extrinsic.leftCols<3>() = -up_in_b;
    J->d_extrinsic.rightCols<3>() = up_in_b * R_bc * so3::skew(lambda * b);
    J->d_lambda = -up_in_b * (R_bc * b);
    J->d_td = -lambda * up_in_b * (R_bc * db_dtd);
  }
  return T_b_c.translation() + lambda * (R_bc * b);
}

/// Ceres output of both height factors (blocks [pose_k, T_b_c, lambda, td]): r / sigma and the
/// whitened Jacobians in the ambient parametrisation of the pose blocks.
bool writeWhitened(double r, const SonarDepthJacobians& J, double inv_sigma, double const* const* parameters,
                   double* residuals, double** jacobians) {
  if (!std::isfinite(r)) return false;
  residuals[0] = inv_sigma * r;
  if (!jacobians) return true;
  writePoseJacobian<1>(inv_sigma * J.d_pose, Eigen::Quaterniond(poseRotation(parameters[0])), jacobians[0]);
  writePoseJacobian<1>(inv_sigma * J.d_extrinsic, Eigen::Quaterniond(poseRotation(parameters[1])), jacobians[1]);
  if (jacobians[2]) jacobians[2][0] = inv_sigma * J.d_lambda;
  if (jacobians[3]) jacobians[3][0] = inv_sigma * J.d_td;
  return true;
}

SonarGateResult gate(double height_difference, double sigma, const SonarDepthOptions& options) {
  SonarGateResult g;
  g.height_difference = height_difference;
  g.chi2 = height_difference * height_difference / (sigma * sigma);
  g.consistent = std::isfinite(g.chi2) && g.chi2 <= options.gate_chi2 &&
                 std::abs(height_difference) <= options.gate_max_height_difference;
  return g;
}
}  // namespace

Eigen::Vector3d sonarHitInBody(double range, const Eigen::Isometry3d& T_b_s) {
  return T_b_s.translation() + range * T_b_s.linear().col(2);
}

Eigen::RowVector3d seabedNormalInBody(const Eigen::Vector2d& slope, const Eigen::Matrix3d& R_l_b) {
  // e_z^T R_k = third row of R_k: the body-frame direction whose component is height in l.
  if (slope.isZero(0.0)) return R_l_b.row(2);
  return Eigen::RowVector3d(-slope.x(), -slope.y(), 1.0) * R_l_b;
}

double sonarDepthResidual(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s,
                          const Eigen::Isometry3d& T_l_bk, const Eigen::Isometry3d& T_b_c, double lambda, double td,
                          SonarDepthJacobians* J, const Eigen::Vector2d& slope) {
  const Eigen::RowVector3d n_in_b = seabedNormalInBody(slope, T_l_bk.linear());
  const Eigen::Vector3d s_b = sonarHitInBody(range, T_b_s);
  const Eigen::Vector3d f_b = featureInBody(anchor, T_b_c, lambda, td, n_in_b, J);
  const Eigen::Vector3d d_b = s_b - f_b;
  const double r = n_in_b.dot(d_b);
  if (J != nullptr) {
    J->d_pose.leftCols<3>().setZero();
    J->d_pose.rightCols<3>() = -n_in_b * so3::skew(d_b);
    J->d_slope = -(T_l_bk.linear() * d_b).head<2>().transpose();
  }
  return r;
}

Eigen::Vector3d featureInL(const FeatureObservation& anchor, const Eigen::Isometry3d& T_l_bk,
                           const Eigen::Isometry3d& T_b_c, double lambda, double td) {
  return T_l_bk * featureInBody(anchor, T_b_c, lambda, td, Eigen::RowVector3d::UnitZ(), nullptr);
}

double sonarHitDistance(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s,
                        const Eigen::Isometry3d& T_l_bk, const Eigen::Isometry3d& T_b_c, double lambda, double td) {
  const Eigen::Vector3d f_b = featureInBody(anchor, T_b_c, lambda, td, Eigen::RowVector3d::UnitZ(), nullptr);
  return (T_l_bk.linear() * (f_b - sonarHitInBody(range, T_b_s))).head<2>().norm();
}

double seabedHeightResidual(const FeatureObservation& anchor, const SeabedPlane& plane, const Eigen::Isometry3d& T_l_bk,
                            const Eigen::Isometry3d& T_b_c, double lambda, double td, SonarDepthJacobians* J) {
  const Eigen::RowVector3d n_in_b = seabedNormalInBody(plane.slope, T_l_bk.linear());
  const Eigen::Vector3d f_b = featureInBody(anchor, T_b_c, lambda, td, n_in_b, J);
  // h + g.(f_xy - xy) - f_z = (h - g.xy) - n^T (p_k + R_k f_b); for g = 0 exactly h - p_z - (R_k f_b)_z.
  double r = 0.0;
  if (plane.slope.isZero(0.0)) {
    r = plane.height - T_l_bk.translation().z() - n_in_b.dot(f_b);
  } else {
    const Eigen::RowVector3d n(-plane.slope.x(), -plane.slope.y(), 1.0);
    r = plane.height - plane.slope.dot(plane.xy) - n.dot(T_l_bk.translation()) - n_in_b.dot(f_b);
  }
  if (J != nullptr) {
    J->d_pose.leftCols<3>() = Eigen::RowVector3d(plane.slope.x(), plane.slope.y(), -1.0);
    J->d_pose.rightCols<3>() = n_in_b * so3::skew(f_b);
    J->d_slope = ((T_l_bk * f_b).head<2>() - plane.xy).transpose();
  }
  return r;
}

SonarGateResult sonarDepthGate(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s,
                               const Eigen::Isometry3d& T_l_bk, const Eigen::Isometry3d& T_b_c, double lambda,
                               double td, double sigma, const SonarDepthOptions& options,
                               const Eigen::Vector2d& slope) {
  return gate(sonarDepthResidual(anchor, range, T_b_s, T_l_bk, T_b_c, lambda, td, nullptr, slope), sigma, options);
}

SonarGateResult seabedHeightGate(const FeatureObservation& anchor, const SeabedPlane& plane,
                                 const Eigen::Isometry3d& T_l_bk, const Eigen::Isometry3d& T_b_c, double lambda,
                                 double td, double sigma, const SonarDepthOptions& options) {
  return gate(seabedHeightResidual(anchor, plane, T_l_bk, T_b_c, lambda, td), sigma, options);
}

SonarHitMeasurement::SonarHitMeasurement(const char* factor, const FeatureObservation& anchor_observation,
                                         double range_m, const Eigen::Isometry3d& sonar_extrinsic, double sigma)
    : anchor(anchor_observation), range(range_m), T_b_s(sonar_extrinsic), inv_sigma(1.0 / sigma) {
  if (!(std::isfinite(range_m) && range_m > 0.0))
    throw std::invalid_argument(std::string(factor) + ": range must be > 0");
  if (!(std::isfinite(sigma) && sigma > 0.0)) throw std::invalid_argument(std::string(factor) + ": sigma must be > 0");
}

bool SonarHitMeasurement::evaluate(double const* const* parameters, const Eigen::Vector2d* slope, double* residuals,
                                   double** jacobians) const {
  SonarDepthJacobians J;
  const double r = sonarDepthResidual(anchor, range, T_b_s, poseBlockToIsometry(parameters[0]),
                                      poseBlockToIsometry(parameters[1]), parameters[2][0], parameters[3][0],
                                      jacobians ? &J : nullptr, slope ? *slope : Eigen::Vector2d::Zero());
  if (!writeWhitened(r, J, inv_sigma, parameters, residuals, jacobians)) return false;
  if (slope && jacobians && jacobians[4]) {
    jacobians[4][0] = inv_sigma * J.d_slope(0);
    jacobians[4][1] = inv_sigma * J.d_slope(1);
  }
  return true;
}

SonarDepthFactor::SonarDepthFactor(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s,
                                   double sigma)
    : hit_("SonarDepthFactor", anchor, range, T_b_s, sigma) {}

bool SonarDepthFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  return hit_.evaluate(parameters, nullptr, residuals, jacobians);
}

SlopedSonarDepthFactor::SlopedSonarDepthFactor(const FeatureObservation& anchor, double range,
                                               const Eigen::Isometry3d& T_b_s, double sigma)
    : hit_("SlopedSonarDepthFactor", anchor, range, T_b_s, sigma) {}

bool SlopedSonarDepthFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Vector2d slope(parameters[4][0], parameters[4][1]);
  return hit_.evaluate(parameters, &slope, residuals, jacobians);
}

SeabedHeightFactor::SeabedHeightFactor(const FeatureObservation& anchor, const SeabedPlane& plane, double sigma)
    : anchor_(anchor), plane_(plane), inv_sigma_(1.0 / sigma) {
  if (!std::isfinite(plane.height) || !plane.xy.allFinite() || !plane.slope.allFinite())
    throw std::invalid_argument("SeabedHeightFactor: the plane must be finite");
  if (!(std::isfinite(sigma) && sigma > 0.0)) throw std::invalid_argument("SeabedHeightFactor: sigma must be > 0");
}

bool SeabedHeightFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  SonarDepthJacobians J;
  const double r =
      seabedHeightResidual(anchor_, plane_, poseBlockToIsometry(parameters[0]), poseBlockToIsometry(parameters[1]),
                           parameters[2][0], parameters[3][0], jacobians ? &J : nullptr);
  return writeWhitened(r, J, inv_sigma_, parameters, residuals, jacobians);
}

}  // namespace vims
