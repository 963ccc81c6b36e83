#include "vims_estimator/factors/pressure_depth_factor.h"

#include <cmath>
#include <stdexcept>

#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

double pressureDepthResidual(double depth, const Eigen::Vector3d& p_bp, const Eigen::Isometry3d& T_l_bk,
                             double surface_z, PressureDepthJacobians* J) {
  const Eigen::RowVector3d up_in_b = T_l_bk.linear().row(2);
  const double r = T_l_bk.translation().z() + up_in_b.dot(p_bp) + depth - surface_z;
  if (J != nullptr) {
    J->d_pose.leftCols<3>() = Eigen::RowVector3d(0.0, 0.0, 1.0);
    J->d_pose.rightCols<3>() = -up_in_b * so3::skew(p_bp);
    J->d_surface = -1.0;
  }
  return r;
}

PressureDepthFactor::PressureDepthFactor(double depth, const Eigen::Vector3d& p_bp, double sigma)
    : depth_(depth), p_bp_(p_bp), inv_sigma_(1.0 / sigma) {
  if (!std::isfinite(depth)) throw std::invalid_argument("PressureDepthFactor: depth must be finite");
  if (!(std::isfinite(sigma) && sigma > 0.0)) throw std::invalid_argument("PressureDepthFactor: sigma must be > 0");
}

bool PressureDepthFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  PressureDepthJacobians J;
  const double r = pressureDepthResidual(depth_, p_bp_, poseBlockToIsometry(parameters[0]), parameters[1][0],
                                         jacobians ? &J : nullptr);
  if (!std::isfinite(r)) return false;
  residuals[0] = inv_sigma_ * r;
  if (!jacobians) return true;
  writePoseJacobian<1>(inv_sigma_ * J.d_pose, Eigen::Quaterniond(poseRotation(parameters[0])), jacobians[0]);
  if (jacobians[1]) jacobians[1][0] = inv_sigma_ * J.d_surface;
  return true;
}

SlopeRandomWalkFactor::SlopeRandomWalkFactor(double sigma) : inv_sigma_(1.0 / sigma) {
  if (!(std::isfinite(sigma) && sigma > 0.0)) throw std::invalid_argument("SlopeRandomWalkFactor: sigma must be > 0");
}

bool SlopeRandomWalkFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  for (int i = 0; i < 2; ++i) residuals[i] = inv_sigma_ * (parameters[1][i] - parameters[0][i]);
  if (!jacobians) return true;
  for (int b = 0; b < 2; ++b) {
    if (!jacobians[b]) continue;
    const double sign = b == 0 ? -1.0 : 1.0;
    jacobians[b][0] = sign * inv_sigma_;
    jacobians[b][1] = 0.0;
    jacobians[b][2] = 0.0;
    jacobians[b][3] = sign * inv_sigma_;
  }
  return true;
}

SlopePriorFactor::SlopePriorFactor(const Eigen::Vector2d& g0, double sigma) : g0_(g0), inv_sigma_(1.0 / sigma) {
  if (!(std::isfinite(sigma) && sigma > 0.0)) throw std::invalid_argument("SlopePriorFactor: sigma must be > 0");
  if (!g0.allFinite()) throw std::invalid_argument("SlopePriorFactor: the prior mean must be finite");
}

bool SlopePriorFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  for (int i = 0; i < 2; ++i) residuals[i] = inv_sigma_ * (parameters[0][i] - g0_(i));
  if (jacobians && jacobians[0]) {
    jacobians[0][0] = inv_sigma_;
    jacobians[0][1] = 0.0;
    jacobians[0][2] = 0.0;
    jacobians[0][3] = inv_sigma_;
  }
  return true;
}

}  // namespace vims
