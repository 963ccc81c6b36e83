#include "vims_estimator/factors/window_hit_factor.h"

#include <cmath>

#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

SeabedPlane windowHitPlane(double range, const Eigen::Isometry3d& T_b_s, const Eigen::Isometry3d& T_l_bj,
                           const Eigen::Vector2d& slope) {
  const Eigen::Vector3d s_l = T_l_bj * sonarHitInBody(range, T_b_s);
  return SeabedPlane{s_l.z(), s_l.head<2>(), slope};
}

namespace {
/// r / sigma and the whitened Jacobians of blocks [pose_a, pose_j, T_b_c, lambda, td] (and of the
/// gradient, block 5, when `slope` is given) for keyframe j's range in `hit`.
bool evaluateWindowHit(const SonarHitMeasurement& hit, double const* const* parameters, const Eigen::Vector2d* slope,
                       double* residuals, double** jacobians) {
  const FeatureObservation& anchor = hit.anchor;
  const double range = hit.range;
  const Eigen::Isometry3d& T_b_s = hit.T_b_s;
  const double inv_sigma = hit.inv_sigma;
  const Eigen::Isometry3d T_l_ba = poseBlockToIsometry(parameters[0]);
  const Eigen::Isometry3d T_l_bj = poseBlockToIsometry(parameters[1]);
  const Eigen::Vector2d g = slope ? *slope : Eigen::Vector2d::Zero();
  const SeabedPlane plane = windowHitPlane(range, T_b_s, T_l_bj, g);
  SonarDepthJacobians J;
  const double r = seabedHeightResidual(anchor, plane, T_l_ba, poseBlockToIsometry(parameters[2]), parameters[3][0],
                                        parameters[4][0], jacobians ? &J : nullptr);
  if (!std::isfinite(r)) return false;
  residuals[0] = inv_sigma * r;
  if (!jacobians) return true;
  const Eigen::RowVector3d n(-g.x(), -g.y(), 1.0);
  Eigen::Matrix<double, 1, 6> d_pose_j;
  d_pose_j.leftCols<3>() = n;
  d_pose_j.rightCols<3>() = -n * T_l_bj.linear() * so3::skew(sonarHitInBody(range, T_b_s));
  writePoseJacobian<1>(inv_sigma * J.d_pose, Eigen::Quaterniond(poseRotation(parameters[0])), jacobians[0]);
  writePoseJacobian<1>(inv_sigma * d_pose_j, Eigen::Quaterniond(poseRotation(parameters[1])), jacobians[1]);
  writePoseJacobian<1>(inv_sigma * J.d_extrinsic, Eigen::Quaterniond(poseRotation(parameters[2])), jacobians[2]);
  if (jacobians[3]) jacobians[3][0] = inv_sigma * J.d_lambda;
  if (jacobians[4]) jacobians[4][0] = inv_sigma * J.d_td;
  if (slope && jacobians[5]) {
    // dr/dg_j = (f_l - s_l)_xy: the plane's gradient acts at keyframe j's hit.
    jacobians[5][0] = inv_sigma * J.d_slope(0);
    jacobians[5][1] = inv_sigma * J.d_slope(1);
  }
  return true;
}
}  // namespace

WindowHitFactor::WindowHitFactor(const FeatureObservation& anchor, double range, const Eigen::Isometry3d& T_b_s,
                                 double sigma)
    : hit_("WindowHitFactor", anchor, range, T_b_s, sigma) {}

bool WindowHitFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  return evaluateWindowHit(hit_, parameters, nullptr, residuals, jacobians);
}

SlopedWindowHitFactor::SlopedWindowHitFactor(const FeatureObservation& anchor, double range,
                                             const Eigen::Isometry3d& T_b_s, double sigma)
    : hit_("SlopedWindowHitFactor", anchor, range, T_b_s, sigma) {}

bool SlopedWindowHitFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const Eigen::Vector2d slope(parameters[5][0], parameters[5][1]);
  return evaluateWindowHit(hit_, parameters, &slope, residuals, jacobians);
}

}  // namespace vims
