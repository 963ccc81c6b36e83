/// Visual-inertial initialisation (VINS-Mono's VisualIMUAlignment) on the SfM of visual_sfm.cpp.
///
/// Notation: c0 is the SfM reference camera frame, p̄_k the SfM camera centre of frame k (unknown
/// scale s), R_c0_bk = R_c0_ck R_b_c^T the body attitude, p_bc the camera position in the body.
/// The body position is p_c0_bk = s p̄_k - R_c0_bk p_bc. With the project's preintegration
/// convention (imu_preintegration.h, gravity vector g pointing down),
///   alpha_ij = R_bi_c0 (p_c0_bj - p_c0_bi - R_c0_bi v_i dt - 1/2 g dt^2)
///   beta_ij  = R_bi_c0 (R_c0_bj v_j - R_c0_bi v_i - g dt)
/// where v_k is the velocity expressed in body frame k. Both are linear in
/// x = [v_0 .. v_n-1, g_c0, s]:
///   alpha_ij - p_bc + R_bi_c0 R_c0_bj p_bc = -dt v_i - 1/2 dt^2 R_bi_c0 g + R_bi_c0 (p̄_j - p̄_i) s
///   beta_ij = -v_i + R_bi_c0 R_c0_bj v_j - dt R_bi_c0 g
/// The accelerometer bias b_a (one constant over the window) is estimated too, with a prior
/// N(0, accel_bias_sigma^2): alpha and beta as measured (at b_a = 0) are corrected by
/// J_alpha_ba b_a and J_beta_ba b_a, so x = [v_0 .. v_n-1, g_c0, b_a, s]. Each pair's 6 rows are
/// whitened with the preintegration covariance of (alpha, beta) and the SfM position noise, so
/// (A^T W A + prior)^-1 is a meaningful covariance: its scale entry gives the excitation test
/// (an unobservable scale, or one confounded with the bias, has a large variance).
/// Gravity refinement: g = |g| (g0/|g0|) + B w with B a tangent basis at g0, 2 unknowns instead of
/// 3, iterated (VINS-Mono's RefineGravity).

#include "vims_estimator/initialization/visual_inertial_initializer.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <sstream>

#include "vims_common/option_table.h"
#include "vims_estimator/so3.h"

namespace vims {

const OptionTable<VisualInertialInitOptions>& VisualInertialInitOptions::optionTable() {
  using O = VisualInertialInitOptions;
  static const auto table =
      OptionTable<O>()
          .flag("enabled", &O::enabled)
          .integer("window_frames", &O::window_frames, Bounds::closed(4, 50))
          .integer("min_relative_pose_features", &O::min_relative_pose_features, Bounds::closed(8, 10000))
          .number("min_relative_pose_parallax_px", &O::min_relative_pose_parallax_px, Bounds::positive())
          .number("ransac_threshold_px", &O::ransac_threshold_px, Bounds::positive())
          .integer("min_sfm_points", &O::min_sfm_points, Bounds::closed(6, 100000))
          .number("max_sfm_rms_px", &O::max_sfm_rms_px, Bounds::positive())
          .number("gravity_norm_tolerance", &O::gravity_norm_tolerance, Bounds::positive())
          .number("max_relative_scale_std", &O::max_relative_scale_std, Bounds::positive())
          .number("accel_bias_sigma", &O::accel_bias_sigma, Bounds::nonNegative())
          .number("sfm_position_sigma_m", &O::sfm_position_sigma_m, Bounds::positive());
  return table;
}

VisualInertialInitOptions VisualInertialInitOptions::fromReader(const ConfigReader& reader) {
  return readOptions<VisualInertialInitOptions>(reader);
}

std::string VisualInertialInitOptions::toYaml() const { return optionTable().toYaml(*this); }

const char* visualInertialInitStatusName(VisualInertialInitStatus status) {
  switch (status) {
    case VisualInertialInitStatus::kSuccess:
      return "success";
    case VisualInertialInitStatus::kTooFewFrames:
      return "too_few_frames";
    case VisualInertialInitStatus::kNoRelativePose:
      return "no_relative_pose";
    case VisualInertialInitStatus::kSfmFailed:
      return "sfm_failed";
    case VisualInertialInitStatus::kInsufficientExcitation:
      return "insufficient_excitation";
    case VisualInertialInitStatus::kAlignmentFailed:
      return "alignment_failed";
  }
  return "unknown";
}

VisualInertialInitializer::VisualInertialInitializer(const Eigen::Isometry3d& T_b_c, double gravity, double focal_px,
                                                     const VisualInertialInitOptions& options)
    : T_b_c_(T_b_c), gravity_(gravity), focal_(focal_px), options_(options) {}

Eigen::Vector3d VisualInertialInitializer::solveGyroBias(const std::vector<InitFrame>& frames,
                                                         const std::vector<Eigen::Quaterniond>& q_c0_b) {
  // Visual relative rotation q_ij = q_c0_bi^-1 q_c0_bj against gamma_ij(b_g):
  //   Log(gamma_ij(b_lin)^-1 q_ij) = J_theta_bg (b_g - b_lin), summed in least squares.
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_lin = Eigen::Vector3d::Zero();
  int pairs = 0;
  for (std::size_t j = 1; j < frames.size(); ++j) {
    const ImuPreintegration& pre = *frames[j].preintegration;
    const Eigen::Quaterniond q_ij = q_c0_b[j - 1].conjugate() * q_c0_b[j];
    const Eigen::Vector3d r = so3::log(pre.gamma().conjugate() * q_ij);
    const Eigen::Matrix3d J = pre.dThetaDbg();
    H += J.transpose() * J;
    g += J.transpose() * (r + J * pre.linearizedGyroBias());
    b_lin += pre.linearizedGyroBias();
    ++pairs;
  }
  if (pairs == 0) return Eigen::Vector3d::Zero();
  const Eigen::Vector3d bg = H.ldlt().solve(g);
  return bg.allFinite() ? bg : Eigen::Vector3d(b_lin / pairs);
}

namespace {

struct AlignmentSystem {
  Eigen::MatrixXd H;  ///< A^T W A
  Eigen::VectorXd g;  ///< A^T W b
};

/// Weighted normal equations of the alignment. gravity_basis: 3x3 (g free) or 3x2 (tangent
/// refinement around g0, which then is the fixed part of g).
AlignmentSystem buildAlignment(const std::vector<InitFrame>& frames, const std::vector<Eigen::Matrix3d>& R_c0_b,
                               const std::vector<Eigen::Vector3d>& pbar, const Eigen::Vector3d& p_bc,
                               const Eigen::MatrixXd& gravity_basis, const Eigen::Vector3d& g0,
                               const VisualInertialInitOptions& options) {
  const int n = static_cast<int>(frames.size());
  const int ng = static_cast<int>(gravity_basis.cols());
  const int dim = 3 * n + ng + 3 + 1;
  AlignmentSystem sys{Eigen::MatrixXd::Zero(dim, dim), Eigen::VectorXd::Zero(dim)};
  const double inv_var_ba = 1.0 / std::max(options.accel_bias_sigma * options.accel_bias_sigma, 1e-12);
  sys.H.block<3, 3>(3 * n + ng, 3 * n + ng) = inv_var_ba * Eigen::Matrix3d::Identity();
  for (int j = 1; j < n; ++j) {
    const int i = j - 1;
    const ImuPreintegration& pre = *frames[j].preintegration;
    const double dt = pre.deltaTime();
    const Eigen::Matrix3d R_bi_c0 = R_c0_b[i].transpose();
    Eigen::Matrix<double, 6, Eigen::Dynamic> A = Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, 6 + ng + 3 + 1);
    Eigen::Matrix<double, 6, 1> b;
    A.block<3, 3>(0, 0) = -dt * Eigen::Matrix3d::Identity();
    A.block(0, 6, 3, ng) = -0.5 * dt * dt * R_bi_c0 * gravity_basis;
    A.block<3, 3>(0, 6 + ng) = -pre.dAlphaDba();
    A.block<3, 1>(0, 6 + ng + 3) = R_bi_c0 * (pbar[j] - pbar[i]);
    // Measured at the linearisation bias b_lin: alpha(b_a) = alpha + J_alpha_ba (b_a - b_lin).
    const Eigen::Vector3d ba_lin = pre.linearizedAccelBias();
    b.head<3>() =
        pre.alpha() - pre.dAlphaDba() * ba_lin - p_bc + R_bi_c0 * R_c0_b[j] * p_bc + 0.5 * dt * dt * R_bi_c0 * g0;
    A.block<3, 3>(3, 0) = -Eigen::Matrix3d::Identity();
    A.block<3, 3>(3, 3) = R_bi_c0 * R_c0_b[j];
    A.block(3, 6, 3, ng) = -dt * R_bi_c0 * gravity_basis;
    A.block<3, 3>(3, 6 + ng) = -pre.dBetaDba();
    b.tail<3>() = pre.beta() - pre.dBetaDba() * ba_lin + dt * R_bi_c0 * g0;
    // Covariance of (alpha, beta): preintegration noise and SfM position noise (two camera
    // centres, metric).
    Eigen::Matrix<double, 6, 6> cov;
    const Matrix15d& P = pre.covariance();
    cov.block<3, 3>(0, 0) = P.block<3, 3>(kIdxAlpha, kIdxAlpha);
    cov.block<3, 3>(0, 3) = P.block<3, 3>(kIdxAlpha, kIdxBeta);
    cov.block<3, 3>(3, 0) = P.block<3, 3>(kIdxBeta, kIdxAlpha);
    cov.block<3, 3>(3, 3) = P.block<3, 3>(kIdxBeta, kIdxBeta);
    cov.block<3, 3>(0, 0) +=
        2.0 * options.sfm_position_sigma_m * options.sfm_position_sigma_m * Eigen::Matrix3d::Identity();
    const Eigen::Matrix<double, 6, 6> W = cov.inverse();
    const Eigen::MatrixXd AtW = A.transpose() * W;
    const Eigen::MatrixXd HA = AtW * A;
    const Eigen::VectorXd gA = AtW * b;
    // Scatter the local columns [v_i (3), v_j (3), g (ng), b_a (3), s (1)] to
    // [3i, 3j, 3n, 3n+ng, 3n+ng+3].
    const std::pair<int, int> blocks[] = {
        {3 * i, 0}, {3 * j, 3}, {3 * n, 6}, {3 * n + ng, 6 + ng}, {3 * n + ng + 3, 6 + ng + 3}};
    const int sizes[] = {3, 3, ng, 3, 1};
    for (int a = 0; a < 5; ++a) {
      sys.g.segment(blocks[a].first, sizes[a]) += gA.segment(blocks[a].second, sizes[a]);
      for (int c = 0; c < 5; ++c) {
        sys.H.block(blocks[a].first, blocks[c].first, sizes[a], sizes[c]) +=
            HA.block(blocks[a].second, blocks[c].second, sizes[a], sizes[c]);
      }
    }
  }
  return sys;
}

/// Solves H x = g; the 1-sigma of the last unknown (the scale) from H^-1. False when H is
/// (numerically) singular: an unobservable direction.
bool solveAlignment(const AlignmentSystem& sys, Eigen::VectorXd* x, double* scale_std) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(sys.H);
  if (eig.info() != Eigen::Success) return false;
  const Eigen::VectorXd ev = eig.eigenvalues();
  if (!(ev.maxCoeff() > 0.0) || ev.minCoeff() <= 1e-12 * ev.maxCoeff()) return false;
  const Eigen::MatrixXd V = eig.eigenvectors();
  const Eigen::MatrixXd Hinv = V * ev.cwiseInverse().asDiagonal() * V.transpose();
  *x = Hinv * sys.g;
  *scale_std = std::sqrt(std::max(0.0, Hinv(sys.H.rows() - 1, sys.H.rows() - 1)));
  return x->allFinite() && std::isfinite(*scale_std);
}

Eigen::Matrix<double, 3, 2> tangentBasis(const Eigen::Vector3d& g) {
  const Eigen::Vector3d a = g.normalized();
  Eigen::Vector3d tmp(0, 0, 1);
  if (std::abs(a.dot(tmp)) > 0.9) tmp = Eigen::Vector3d(1, 0, 0);
  const Eigen::Vector3d b1 = (tmp - a * a.dot(tmp)).normalized();
  const Eigen::Vector3d b2 = a.cross(b1);
  Eigen::Matrix<double, 3, 2> B;
  B << b1, b2;
  return B;
}

}  // namespace

VisualInertialInitResult VisualInertialInitializer::initialize(std::vector<InitFrame>& frames) const {
  VisualInertialInitResult out;
  const int n = static_cast<int>(frames.size());
  if (n < 4) {
    out.status = VisualInertialInitStatus::kTooFewFrames;
    out.message = "need at least 4 frames, have " + std::to_string(n);
    return out;
  }
  for (int k = 1; k < n; ++k) {
    if (!frames[k].preintegration || !(frames[k].preintegration->deltaTime() > 0.0)) {
      out.status = VisualInertialInitStatus::kTooFewFrames;
      out.message = "frame " + std::to_string(k) + " has no IMU preintegration";
      return out;
    }
  }

  // 1. Visual SfM.
  const VisualSfmResult sfm = solveVisualSfm(frames, focal_, options_);
  if (!sfm.ok) {
    out.status = sfm.reference_frame < 0 && sfm.T_c0_c.empty() && sfm.message.rfind("no frame", 0) == 0
                     ? VisualInertialInitStatus::kNoRelativePose
                     : VisualInertialInitStatus::kSfmFailed;
    out.message = "visual SfM: " + sfm.message;
    return out;
  }
  const Eigen::Matrix3d R_b_c = T_b_c_.linear();
  const Eigen::Vector3d p_bc = T_b_c_.translation();
  std::vector<Eigen::Matrix3d> R_c0_b(n);
  std::vector<Eigen::Quaterniond> q_c0_b(n);
  std::vector<Eigen::Vector3d> pbar(n);
  for (int k = 0; k < n; ++k) {
    R_c0_b[k] = sfm.T_c0_c[k].linear() * R_b_c.transpose();
    q_c0_b[k] = Eigen::Quaterniond(R_c0_b[k]).normalized();
    pbar[k] = sfm.T_c0_c[k].translation();
  }

  // 2. Gyroscope bias (two Gauss-Newton steps: the second at the repropagated preintegrations).
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  for (int iteration = 0; iteration < 2; ++iteration) {
    bg = solveGyroBias(frames, q_c0_b);
    if (!bg.allFinite() || bg.norm() > 1.0) {
      out.status = VisualInertialInitStatus::kAlignmentFailed;
      out.message = "gyroscope bias estimate not plausible";
      return out;
    }
    for (int k = 1; k < n; ++k) {
      frames[k].preintegration->repropagate(frames[k].preintegration->linearizedAccelBias(), bg);
    }
  }
  out.gyro_bias = bg;

  // 3. Linear alignment with free gravity.
  Eigen::VectorXd x;
  double scale_std = 0.0;
  const AlignmentSystem free_sys =
      buildAlignment(frames, R_c0_b, pbar, p_bc, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), options_);
  if (!solveAlignment(free_sys, &x, &scale_std)) {
    out.status = VisualInertialInitStatus::kInsufficientExcitation;
    out.message = "linear alignment is singular: velocity and scale are not separable (no acceleration)";
    return out;
  }
  Eigen::Vector3d g = x.segment<3>(3 * n);
  double s = x(3 * n + 6);
  if (!(s > 0.0) || std::abs(g.norm() - gravity_) > options_.gravity_norm_tolerance) {
    std::ostringstream os;
    os << "linear alignment gives scale " << s << " and |g| " << g.norm() << " (expected " << gravity_ << ")";
    // An unobservable scale shows up as a huge uncertainty: report it as such.
    const bool weak = std::abs(s) < 1e-9 || scale_std / std::abs(s) > options_.max_relative_scale_std;
    out.status = weak ? VisualInertialInitStatus::kInsufficientExcitation : VisualInertialInitStatus::kAlignmentFailed;
    out.message = os.str();
    return out;
  }

  // 4. Gravity refinement on the tangent space (|g| fixed).
  g = gravity_ * g.normalized();
  for (int iteration = 0; iteration < 4; ++iteration) {
    const Eigen::Matrix<double, 3, 2> B = tangentBasis(g);
    const AlignmentSystem sys = buildAlignment(frames, R_c0_b, pbar, p_bc, B, g, options_);
    if (!solveAlignment(sys, &x, &scale_std)) {
      out.status = VisualInertialInitStatus::kInsufficientExcitation;
      out.message = "refined alignment is singular: scale not observable";
      return out;
    }
    g = gravity_ * (g + B * x.segment<2>(3 * n)).normalized();
    s = x(3 * n + 5);
    out.accel_bias = x.segment<3>(3 * n + 2);
  }
  out.scale = s;
  out.scale_relative_std = s > 0.0 ? scale_std / s : std::numeric_limits<double>::infinity();
  if (!(s > 0.0)) {
    out.status = VisualInertialInitStatus::kAlignmentFailed;
    out.message = "refined scale is not positive";
    return out;
  }
  // An accelerometer bias far outside its prior means the alignment explained the data with the
  // bias instead of the motion (seen on the tank sequence: 0.5 m/s^2 with a wrong scale).
  if (out.accel_bias.norm() > 3.0 * options_.accel_bias_sigma) {
    std::ostringstream os;
    os << "accelerometer bias estimate " << out.accel_bias.norm() << " m/s^2 exceeds 3 sigma of its prior (scale " << s
       << ")";
    out.status = VisualInertialInitStatus::kAlignmentFailed;
    out.message = os.str();
    return out;
  }
  if (out.scale_relative_std > options_.max_relative_scale_std) {
    std::ostringstream os;
    os << "scale " << s << " has a relative 1-sigma of " << out.scale_relative_std << " (> "
       << options_.max_relative_scale_std << "): too little acceleration";
    out.status = VisualInertialInitStatus::kInsufficientExcitation;
    out.message = os.str();
    return out;
  }

  // 5. Gravity-aligned world frame: g -> [0 0 -|g|], yaw of the first body pose removed.
  Eigen::Matrix3d R_w_c0 =
      Eigen::Quaterniond::FromTwoVectors(g.normalized(), -Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d R_w_b0 = R_w_c0 * R_c0_b[0];
  const double yaw = std::atan2(R_w_b0(1, 0), R_w_b0(0, 0));
  R_w_c0 = Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R_w_c0;
  const Eigen::Vector3d p_c0_b0 = s * pbar[0] - R_c0_b[0] * p_bc;
  out.T_w_b.resize(n);
  out.v_w_b.resize(n);
  for (int k = 0; k < n; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R_w_c0 * R_c0_b[k];
    T.translation() = R_w_c0 * (s * pbar[k] - R_c0_b[k] * p_bc - p_c0_b0);
    out.T_w_b[k] = T;
    out.v_w_b[k] = R_w_c0 * R_c0_b[k] * x.segment<3>(3 * k);
  }
  for (const auto& [id, p] : sfm.points_c0) out.points_w[id] = R_w_c0 * (s * p - p_c0_b0);
  std::ostringstream os;
  os << "scale " << s << " (relative 1-sigma " << out.scale_relative_std << "), gyro bias " << bg.transpose()
     << ", accelerometer bias " << out.accel_bias.transpose() << ", SfM RMS " << sfm.rms_px << " px, "
     << sfm.points_c0.size() << " points";
  out.message = os.str();
  out.status = VisualInertialInitStatus::kSuccess;
  return out;
}

}  // namespace vims
