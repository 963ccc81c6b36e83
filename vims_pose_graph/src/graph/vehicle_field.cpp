#include "vims_pose_graph/vehicle_field.h"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "vims_common/option_table.h"

namespace vims {

namespace {
// A session whose samples weigh less than this fraction of all of them is dropped (its field is
// no longer determined; its share of the sums is negligible).
constexpr double kDroppedSessionWeight = 1e-9;
// Alternations of the rank-one fit (each a 6x6 solve; the cost settles within a few).
constexpr int kRankOneIterations = 10;
}  // namespace

std::optional<ForwardMotion> forwardMotion(const std::vector<TimedPosition>& positions, double t,
                                           const Eigen::Matrix3d& R_odom_b) {
  // p(s) = c0 + c1 s + c2 s^2 with s = t_i - t, per axis; v = c1, a = 2 c2.
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d AtP = Eigen::Matrix3d::Zero();  // columns: x, y, z
  for (const TimedPosition& q : positions) {
    const double s = q.t - t;
    const Eigen::Vector3d row(1.0, s, s * s);
    AtA += row * row.transpose();
    AtP += row * q.p_odom.transpose();
  }
  Eigen::LDLT<Eigen::Matrix3d> ldlt(AtA);
  // Three distinct times make AtA positive definite; fewer leave it singular.
  if (positions.size() < 3 || ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
      std::abs(AtA.determinant()) < 1e-12 * std::pow(AtA.trace(), 3))
    return std::nullopt;
  const Eigen::Matrix3d coefficients = ldlt.solve(AtP);
  const Eigen::Vector3d velocity = coefficients.row(1).transpose();
  const Eigen::Vector3d acceleration = 2.0 * coefficients.row(2).transpose();
  if (!velocity.allFinite() || !acceleration.allFinite()) return std::nullopt;
  const Eigen::Vector3d forward = R_odom_b.col(0);
  return ForwardMotion{forward.dot(velocity), forward.dot(acceleration)};
}

const OptionTable<VehicleFieldOptions>& VehicleFieldOptions::optionTable() {
  using O = VehicleFieldOptions;
  static const auto table = OptionTable<O>()
                                .flag("enabled", &O::enabled)
                                .number("memory_s", &O::memory_s, Bounds::closed(1.0, 1e7))
                                .scaledNumber("prior_ut", &O::prior_tesla, 1e-6, Bounds::closed(1e-3, 1e4))
                                .scaledNumber("residual_nt", &O::residual_tesla, 1e-9, Bounds::closed(1e-3, 1e6))
                                .integer("min_samples", &O::min_samples, Bounds::closed(1, 1000000))
                                .number("min_explained_fraction", &O::min_explained_fraction, Bounds::closed(0.0, 1.0));
  return table;
}

VehicleFieldEstimator::VehicleFieldEstimator(const VehicleFieldOptions& options) : options_(options) {}

Eigen::Matrix<double, VehicleFieldEstimator::kRegressors, 1> VehicleFieldEstimator::regressors(
    const ForwardMotion& motion) {
  const double v = motion.speed_mps;
  return Eigen::Matrix<double, kRegressors, 1>(1.0, v, v * std::abs(v), motion.accel_mps2);
}

void VehicleFieldEstimator::forget(double t) {
  if (latest_t_ > -1e299 && t > latest_t_) {
    const double f = std::exp(-(t - latest_t_) / options_.memory_s);
    A_theta_ *= f;
    b_theta_ *= f;
    yy_ *= f;
    total_weight_ *= f;
    for (auto it = sessions_.begin(); it != sessions_.end();) {
      SessionSums& s = it->second;
      s.weight *= f;
      s.A_Ftheta *= f;
      s.b_F *= f;
      it = s.weight < kDroppedSessionWeight * total_weight_ ? sessions_.erase(it) : std::next(it);
    }
  }
  latest_t_ = std::max(latest_t_, t);
}

void VehicleFieldEstimator::add(uint32_t session, double t, const Eigen::Matrix3d& R_odom_b,
                                const Eigen::Vector3d& field_b, const ForwardMotion& motion) {
  if (!options_.enabled || !std::isfinite(t) || !R_odom_b.allFinite() || !field_b.allFinite() ||
      !std::isfinite(motion.speed_mps) || !std::isfinite(motion.accel_mps2))
    return;
  forget(t);
  // Phi = [I, v I, v|v| I, a I] (3 x 12): the sample's Jacobian with respect to the vectors.
  const Eigen::Matrix<double, kRegressors, 1> rho = regressors(motion);
  Eigen::Matrix<double, 3, kUnknowns> Phi;
  for (int k = 0; k < kRegressors; ++k) Phi.block<3, 3>(0, 3 * k) = rho(k) * Eigen::Matrix3d::Identity();
  A_theta_ += Phi.transpose() * Phi;
  b_theta_ += Phi.transpose() * field_b;
  yy_ += field_b.squaredNorm();
  total_weight_ += 1.0;
  // The session's field enters through R_odom_b^T: its block of the normal equations is
  // sum R R^T = (sum of weights) I, and its coupling to the vectors sum R Phi.
  SessionSums& s = sessions_[session];
  s.weight += 1.0;
  s.A_Ftheta += R_odom_b * Phi;
  s.b_F += R_odom_b * field_b;
  ++num_samples_;
  solve();
}

VehicleFieldEstimator::Vector VehicleFieldEstimator::rankOneThrustFit(const Matrix& H, const Vector& g) {
  // Unconstrained first: the starting point, and the answer where the rank-one fit fails.
  const Vector full = H.ldlt().solve(g);
  // theta = [b0; c_v d; c_vv d; c_a d]: for a fixed direction d (or fixed c) linear in the rest,
  // so alternate the two linear least-squares problems (each lowers the cost), from the
  // dominant direction of the unconstrained fit.
  Eigen::Matrix3d M;
  for (int j = 0; j < 3; ++j) M.col(j) = full.segment<3>(3 + 3 * j);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  if (!(svd.singularValues()(0) > 0.0)) return full;
  Eigen::Vector3d d = svd.matrixU().col(0);
  Eigen::Vector3d c = svd.singularValues()(0) * svd.matrixV().col(0);
  Vector theta = full;
  Eigen::Matrix<double, kUnknowns, 6> P;
  for (int iteration = 0; iteration < kRankOneIterations; ++iteration) {
    for (int fix_direction = 1; fix_direction >= 0; --fix_direction) {
      P.setZero();
      P.block<3, 3>(0, 0) = Eigen::Matrix3d::Identity();
      for (int j = 0; j < 3; ++j) {
        if (fix_direction)
          P.block<3, 1>(3 + 3 * j, 3 + j) = d;
        else
          P.block<3, 3>(3 + 3 * j, 3) = c(j) * Eigen::Matrix3d::Identity();
      }
      const Eigen::Matrix<double, 6, 6> Hr = P.transpose() * H * P;
      const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(Hr);
      const Eigen::Matrix<double, 6, 1> x = ldlt.solve(P.transpose() * g);
      if (ldlt.info() != Eigen::Success || !x.allFinite()) return full;
      if (fix_direction) {
        c = x.tail<3>();
      } else {
        const double norm = x.tail<3>().norm();
        if (!(norm > 0.0)) return full;
        d = x.tail<3>() / norm;
        c *= norm;
      }
      theta = P * x;
    }
  }
  return theta;
}

void VehicleFieldEstimator::solve() {
  // Each session's field eliminated (Schur complement of its diagonal block), plus the prior.
  Matrix H = A_theta_;
  Vector g = b_theta_;
  for (const auto& entry : sessions_) {
    const SessionSums& s = entry.second;
    H -= s.A_Ftheta.transpose() * s.A_Ftheta / s.weight;
    g -= s.A_Ftheta.transpose() * s.b_F / s.weight;
  }
  const double prior = std::pow(options_.residual_tesla / options_.prior_tesla, 2);
  H.diagonal().array() += prior;
  parameters_ = rankOneThrustFit(H, g);
  // Residual sum of squares of the data at the solution, the sessions' fields at their optimum.
  double rss = yy_ - 2.0 * parameters_.dot(b_theta_) + parameters_.dot(A_theta_ * parameters_);
  for (const auto& entry : sessions_) {
    const SessionSums& s = entry.second;
    rss -= (s.b_F - s.A_Ftheta * parameters_).squaredNorm() / s.weight;
  }
  residual_sum_ = std::max(0.0, rss);
  // The same without a vehicle field (each session's field alone).
  double rss0 = yy_;
  for (const auto& entry : sessions_) rss0 -= entry.second.b_F.squaredNorm() / entry.second.weight;
  constant_field_residual_sum_ = std::max(0.0, rss0);
}

double VehicleFieldEstimator::explainedFraction() const {
  // Adjusted for the unknowns each fit spends (3 per session field, and the 12 of the vehicle's):
  // with few samples any 12 numbers explain much of the spread.
  const double observations = 3.0 * total_weight_;
  const double session_unknowns = 3.0 * static_cast<double>(sessions_.size());
  const double dof_constant = observations - session_unknowns;
  const double dof_fit = dof_constant - kUnknowns;
  if (!(constant_field_residual_sum_ > 0.0) || dof_fit <= 0.0) return 0.0;
  return std::max(0.0, 1.0 - (residual_sum_ / dof_fit) / (constant_field_residual_sum_ / dof_constant));
}

bool VehicleFieldEstimator::applied() const {
  return options_.enabled && num_samples_ >= static_cast<size_t>(options_.min_samples) &&
         explainedFraction() >= options_.min_explained_fraction;
}

double VehicleFieldEstimator::residualRms() const {
  if (total_weight_ <= 0.0) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(residual_sum_ / (3.0 * total_weight_));
}

Eigen::Vector3d VehicleFieldEstimator::vehicleField(const ForwardMotion& motion) const {
  return applied() ? fittedField(motion) : Eigen::Vector3d::Zero();
}

Eigen::Vector3d VehicleFieldEstimator::fittedField(const ForwardMotion& motion) const {
  const Eigen::Matrix<double, kRegressors, 1> rho = regressors(motion);
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (int k = 0; k < kRegressors; ++k) b += rho(k) * parameters_.segment<3>(3 * k);
  return b;
}

}  // namespace vims
