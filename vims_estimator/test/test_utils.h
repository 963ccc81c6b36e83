#pragma once
/// @file test_utils.h
/// @brief Helpers shared by the vims_estimator tests: random states and a Jacobian checker that
/// compares a cost function's analytic Jacobians, mapped to the tangent space of each block's
/// manifold, with central differences of r(x (+) delta).

#include <ceres/cost_function.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <iomanip>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "vims_estimator/factors/marginalization_factor.h"  // BlockManifold
#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {
namespace test {

/// A number in scientific notation, for RecordProperty() diagnostics.
inline std::string sci(double v) {
  std::ostringstream os;
  os << std::scientific << std::setprecision(3) << v;
  return os.str();
}

inline Eigen::Vector3d randomVector(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return scale * Eigen::Vector3d(u(rng), u(rng), u(rng));
}

inline Eigen::Quaterniond randomRotation(std::mt19937& rng, double max_angle) {
  Eigen::Vector3d axis = randomVector(rng, 1.0);
  if (axis.norm() < 1e-3) axis = Eigen::Vector3d::UnitX();
  std::uniform_real_distribution<double> u(0.0, max_angle);
  return so3::exp(axis.normalized() * u(rng));
}

inline std::vector<double> poseBlock(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  std::vector<double> b(kPoseSize);
  setPose(b.data(), p, q);
  return b;
}

inline std::vector<double> poseBlock(const Eigen::Isometry3d& T) {
  return poseBlock(T.translation(), Eigen::Quaterniond(T.linear()));
}

/// Evaluates the residual of `cost` at `params` (no Jacobians).
inline Eigen::VectorXd evaluateResidual(const ceres::CostFunction& cost,
                                        const std::vector<std::vector<double>>& params) {
  std::vector<const double*> ptrs;
  for (const auto& p : params) ptrs.push_back(p.data());
  Eigen::VectorXd r(cost.num_residuals());
  EXPECT_TRUE(cost.Evaluate(ptrs.data(), r.data(), nullptr));
  return r;
}

/// Analytic tangent Jacobian of block b: J_ambient * PlusJacobian (pose) or J_ambient.
inline std::vector<Eigen::MatrixXd> analyticTangentJacobians(const ceres::CostFunction& cost,
                                                             const std::vector<std::vector<double>>& params,
                                                             const std::vector<BlockManifold>& manifolds) {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const int m = cost.num_residuals();
  std::vector<const double*> ptrs;
  std::vector<RowMajor> J(params.size());
  std::vector<double*> jptrs;
  for (size_t b = 0; b < params.size(); ++b) {
    ptrs.push_back(params[b].data());
    J[b].setConstant(m, static_cast<int>(params[b].size()), std::numeric_limits<double>::quiet_NaN());
    jptrs.push_back(J[b].data());
  }
  Eigen::VectorXd r(m);
  EXPECT_TRUE(cost.Evaluate(ptrs.data(), r.data(), jptrs.data()));
  std::vector<Eigen::MatrixXd> out;
  for (size_t b = 0; b < params.size(); ++b) {
    if (manifolds[b] == BlockManifold::kPose) {
      Eigen::Matrix<double, kPoseSize, kPoseTangentSize, Eigen::RowMajor> plus;
      PoseManifold().PlusJacobian(params[b].data(), plus.data());
      out.push_back(J[b] * plus);
    } else {
      out.push_back(J[b]);
    }
  }
  return out;
}

/// Central differences of r(x_b (+) delta) for block b in its manifold's tangent space.
inline Eigen::MatrixXd numericTangentJacobian(const ceres::CostFunction& cost, std::vector<std::vector<double>> params,
                                              size_t b, BlockManifold manifold, double h) {
  const int m = cost.num_residuals();
  const int n = manifold == BlockManifold::kPose ? kPoseTangentSize : static_cast<int>(params[b].size());
  const std::vector<double> x = params[b];
  Eigen::MatrixXd J(m, n);
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd r_pm[2];
    for (int s = 0; s < 2; ++s) {
      const double step = s == 0 ? h : -h;
      if (manifold == BlockManifold::kPose) {
        Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
        delta(k) = step;
        PoseManifold().Plus(x.data(), delta.data(), params[b].data());
      } else {
        params[b] = x;
        params[b][k] += step;
      }
      r_pm[s] = evaluateResidual(cost, params);
    }
    J.col(k) = (r_pm[0] - r_pm[1]) / (2.0 * h);
  }
  return J;
}

/// Checks every block, row by row: max_j |J_analytic(i,j) - J_numeric(i,j)| <= rel_tol * s_i with
/// s_i = max(1, largest |J_numeric| in row i over all blocks). Scaling per row keeps a small row
/// (e.g. a bias residual next to a whitened position residual) from hiding its errors.
/// Returns the worst relative error.
inline double checkJacobians(const ceres::CostFunction& cost, const std::vector<std::vector<double>>& params,
                             const std::vector<BlockManifold>& manifolds, double h, double rel_tol,
                             const std::string& label) {
  const std::vector<Eigen::MatrixXd> Ja = analyticTangentJacobians(cost, params, manifolds);
  std::vector<Eigen::MatrixXd> Jn;
  Eigen::VectorXd row_scale = Eigen::VectorXd::Ones(cost.num_residuals());
  for (size_t b = 0; b < params.size(); ++b) {
    Jn.push_back(numericTangentJacobian(cost, params, b, manifolds[b], h));
    row_scale = row_scale.cwiseMax(Jn.back().cwiseAbs().rowwise().maxCoeff());
  }
  double worst = 0.0;
  for (size_t b = 0; b < params.size(); ++b) {
    EXPECT_TRUE(Ja[b].allFinite()) << label << ": block " << b << " has unset/non-finite entries";
    const Eigen::MatrixXd rel = (Ja[b] - Jn[b]).cwiseAbs().array().colwise() / row_scale.array();
    const double err = rel.size() > 0 ? rel.maxCoeff() : 0.0;
    worst = std::max(worst, err);
    EXPECT_LE(err, rel_tol) << label << ": block " << b << "\nanalytic:\n" << Ja[b] << "\nnumeric:\n" << Jn[b];
  }
  return worst;
}

}  // namespace test
}  // namespace vims
