#include "vims_pose_graph/loop_measurement.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "vims_pose_graph/angles.h"

namespace vims {

namespace {

/// The loop's geometry for a 4-DoF state z = (p_l, yaw): the query body in the match body frame.
struct FourDofLoop {
  Eigen::Matrix3d L_m;  ///< match levelling
  Eigen::Matrix3d L_q;  ///< query levelling
  Eigen::Isometry3d T_c_b;
  Eigen::Isometry3d T_bq_odomq;

  Eigen::Isometry3d matchQuery(const Eigen::Vector4d& z) const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = L_m.transpose() * rotationZ(z[3]) * L_q;
    T.translation() = L_m.transpose() * z.head<3>();
    return T;
  }
  /// Reprojection residuals (2 per inlier); false when a point is not in front of the camera.
  bool residuals(const LoopInlierGeometry& g, const Eigen::Vector4d& z, Eigen::VectorXd* r) const {
    const Eigen::Isometry3d T_cm_odomq = T_c_b * matchQuery(z) * T_bq_odomq;
    const size_t n = g.points_odom_query.size();
    r->resize(static_cast<Eigen::Index>(2 * n));
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d p_c = T_cm_odomq * g.points_odom_query[i];
      if (!(p_c.z() > 1e-6)) return false;
      r->segment<2>(static_cast<Eigen::Index>(2 * i)) = p_c.head<2>() / p_c.z() - g.normalized_match[i];
    }
    return true;
  }
  /// Central differences: the residuals are smooth and the steps far above rounding.
  bool jacobian(const LoopInlierGeometry& g, const Eigen::Vector4d& z, Eigen::MatrixXd* J) const {
    constexpr double kStep = 1e-6;  // [m], [rad]
    J->resize(static_cast<Eigen::Index>(2 * g.points_odom_query.size()), 4);
    Eigen::VectorXd rp, rm;
    for (int k = 0; k < 4; ++k) {
      Eigen::Vector4d d = Eigen::Vector4d::Zero();
      d[k] = kStep;
      if (!residuals(g, z + d, &rp) || !residuals(g, z - d, &rm)) return false;
      J->col(k) = (rp - rm) / (2.0 * kStep);
    }
    return true;
  }
};

}  // namespace

std::optional<LoopMeasurement> refineLoopMeasurement(const LoopInlierGeometry& inliers,
                                                     const Eigen::Isometry3d& T_match_query_pnp,
                                                     const Eigen::Isometry3d& T_odomq_bq,
                                                     const Eigen::Isometry3d& T_b_c, double pitch_match,
                                                     double roll_match) {
  const size_t n = inliers.points_odom_query.size();
  if (n < 4 || inliers.normalized_match.size() != n) return std::nullopt;
  FourDofLoop loop;
  loop.L_m = rotationFromPitchRoll(pitch_match, roll_match);
  const YawPitchRoll query_attitude = yawPitchRollFromRotation(T_odomq_bq.linear());
  loop.L_q = rotationFromPitchRoll(query_attitude.pitch, query_attitude.roll);
  loop.T_c_b = T_b_c.inverse();
  loop.T_bq_odomq = T_odomq_bq.inverse();

  Eigen::Vector4d z;
  z.head<3>() = loop.L_m * T_match_query_pnp.translation();
  z[3] = yawPitchRollFromRotation(loop.L_m * T_match_query_pnp.linear()).yaw;
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  if (!loop.residuals(inliers, z, &r)) return std::nullopt;
  double cost = r.squaredNorm();
  LoopMeasurement m;
  // Gauss-Newton: the PnP pose is within a tilt's worth of the optimum, a few steps converge.
  constexpr int kMaxIterations = 10;
  for (; m.iterations < kMaxIterations; ++m.iterations) {
    if (!loop.jacobian(inliers, z, &J)) return std::nullopt;
    const Eigen::Matrix4d H = J.transpose() * J;
    const Eigen::Vector4d step = H.ldlt().solve(-J.transpose() * r);
    if (!step.allFinite()) return std::nullopt;
    Eigen::VectorXd r_new;
    if (!loop.residuals(inliers, z + step, &r_new)) return std::nullopt;
    const double cost_new = r_new.squaredNorm();
    if (cost_new > cost) break;  // at the optimum up to rounding
    z += step;
    r = r_new;
    const bool converged = cost - cost_new <= 1e-10 * cost || step.norm() < 1e-9;
    cost = cost_new;
    if (converged) break;
  }
  if (!loop.jacobian(inliers, z, &J)) return std::nullopt;
  const Eigen::Matrix4d H = J.transpose() * J;
  const Eigen::LDLT<Eigen::Matrix4d> ldlt(H);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 1e-12 * H.trace()).all()) return std::nullopt;
  const double s2 = cost / static_cast<double>(2 * n - 4);
  m.residual_rms = std::sqrt(s2);
  m.covariance = s2 * ldlt.solve(Eigen::Matrix4d::Identity());
  m.T_match_query = loop.matchQuery(z);
  if (!m.covariance.allFinite() || !m.T_match_query.matrix().allFinite()) return std::nullopt;
  return m;
}

}  // namespace vims
