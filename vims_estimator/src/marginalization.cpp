#include "vims_estimator/marginalization.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "vims_common/option_table.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

namespace {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// Eigenvalue cut-off for a symmetric PSD matrix with largest eigenvalue s_max.
double eigenThreshold(double s_max, const MarginalizationOptions& o) {
  return std::max(o.eigenvalue_absolute_threshold, o.eigenvalue_relative_threshold * s_max);
}

/// Applies a robust loss to a linearised residual block the way Ceres does (Triggs correction),
/// so that 1/2 |r'|^2 and J'^T J' match rho's value, gradient and (Gauss-Newton) curvature.
void applyLoss(const ceres::LossFunction& loss, Eigen::VectorXd* r, Eigen::MatrixXd* J) {
  const double s = r->squaredNorm();
  double rho[3];
  loss.Evaluate(s, rho);
  const double sqrt_rho1 = std::sqrt(std::max(rho[1], 0.0));
  double residual_scaling, alpha_sq_norm;
  if (s == 0.0 || rho[2] <= 0.0) {
    residual_scaling = sqrt_rho1;
    alpha_sq_norm = 0.0;
  } else {
    const double D = 1.0 + 2.0 * s * rho[2] / rho[1];
    const double alpha = 1.0 - std::sqrt(D);
    residual_scaling = sqrt_rho1 / (1.0 - alpha);
    alpha_sq_norm = alpha / s;
  }
  if (alpha_sq_norm != 0.0) {
    *J = sqrt_rho1 * (*J - alpha_sq_norm * (*r) * (r->transpose() * (*J)));
  } else {
    *J *= sqrt_rho1;
  }
  *r *= residual_scaling;
}

}  // namespace

const OptionTable<MarginalizationOptions>& MarginalizationOptions::optionTable() {
  using O = MarginalizationOptions;
  static const auto table =
      OptionTable<O>()
          .number("eigenvalue_relative_threshold", &O::eigenvalue_relative_threshold, Bounds::closed(1e-300, 1.0))
          .number("eigenvalue_absolute_threshold", &O::eigenvalue_absolute_threshold, Bounds::positive());
  return table;
}

MarginalizationOptions MarginalizationOptions::fromReader(const ConfigReader& reader) {
  return readOptions<MarginalizationOptions>(reader);
}

std::string MarginalizationOptions::toYaml() const { return optionTable().toYaml(*this); }

MarginalizationInfo::MarginalizationInfo(MarginalizationOptions options) : options_(options) {}

void MarginalizationInfo::addParameterBlock(double* block, int ambient_size, BlockManifold manifold) {
  if (block == nullptr || ambient_size <= 0) throw std::invalid_argument("MarginalizationInfo: bad parameter block");
  if (manifold == BlockManifold::kPose && ambient_size != kPoseSize) {
    throw std::invalid_argument("MarginalizationInfo: a pose block must have 7 parameters");
  }
  auto it = block_info_.find(block);
  if (it != block_info_.end()) {
    if (it->second.ambient_size != ambient_size || it->second.manifold != manifold) {
      throw std::invalid_argument("MarginalizationInfo: block re-declared with another size or manifold");
    }
    return;
  }
  block_info_[block] = BlockInfo{ambient_size, manifold};
}

void MarginalizationInfo::addResidualBlock(std::shared_ptr<const ceres::CostFunction> cost,
                                           std::shared_ptr<const ceres::LossFunction> loss,
                                           const std::vector<double*>& blocks) {
  if (!cost) throw std::invalid_argument("MarginalizationInfo: null cost function");
  const std::vector<int32_t>& sizes = cost->parameter_block_sizes();
  if (sizes.size() != blocks.size()) {
    throw std::invalid_argument("MarginalizationInfo: number of blocks does not match the cost function");
  }
  for (size_t i = 0; i < blocks.size(); ++i) {
    auto it = block_info_.find(blocks[i]);
    if (it == block_info_.end()) throw std::invalid_argument("MarginalizationInfo: undeclared parameter block");
    if (it->second.ambient_size != sizes[i]) {
      throw std::invalid_argument("MarginalizationInfo: declared block size differs from the cost function's");
    }
  }
  residuals_.push_back(ResidualInfo{std::move(cost), std::move(loss), blocks});
}

std::shared_ptr<const MarginalizationPrior> MarginalizationInfo::marginalize(const std::vector<double*>& drop) const {
  const std::set<double*> drop_set(drop.begin(), drop.end());
  for (double* d : drop_set) {
    if (!block_info_.count(d)) throw std::invalid_argument("MarginalizationInfo: drop block not declared");
  }

  // Column layout: dropped blocks first (in `drop` order), then kept blocks by first appearance.
  std::map<double*, int> column;
  std::vector<double*> kept;
  int n_drop = 0;
  for (double* d : drop) {
    if (column.count(d)) continue;
    column[d] = n_drop;
    const BlockInfo& info = block_info_.at(d);
    n_drop += tangentSize(info.ambient_size, info.manifold);
  }
  int n_total = n_drop;
  for (const ResidualInfo& res : residuals_) {
    bool touches_drop = false;
    for (double* b : res.blocks) {
      if (drop_set.count(b)) {
        touches_drop = true;
      } else if (!column.count(b)) {
        column[b] = n_total;
        const BlockInfo& info = block_info_.at(b);
        n_total += tangentSize(info.ambient_size, info.manifold);
        kept.push_back(b);
      }
    }
    if (!touches_drop) {
      throw std::invalid_argument("MarginalizationInfo: a residual block touches no dropped block");
    }
  }
  const int n_keep = n_total - n_drop;
  last_discarded_ = 0;
  if (n_keep == 0) return nullptr;

  // Linearise and accumulate H = sum J^T J, b = sum J^T r in tangent coordinates.
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n_total, n_total);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n_total);
  const PoseManifold pose_manifold;
  for (const ResidualInfo& res : residuals_) {
    const int m = res.cost->num_residuals();
    const std::vector<int32_t>& sizes = res.cost->parameter_block_sizes();
    Eigen::VectorXd r(m);
    std::vector<RowMajorMatrix> J_ambient(res.blocks.size());
    std::vector<double*> J_ptrs(res.blocks.size());
    for (size_t i = 0; i < res.blocks.size(); ++i) {
      J_ambient[i].resize(m, sizes[i]);
      J_ptrs[i] = J_ambient[i].data();
    }
    std::vector<const double*> values(res.blocks.begin(), res.blocks.end());
    if (!res.cost->Evaluate(values.data(), r.data(), J_ptrs.data())) {
      throw std::runtime_error("MarginalizationInfo: a cost function failed to evaluate");
    }

    // Stack the tangent Jacobians of this residual block side by side.
    std::vector<int> tangent_sizes(res.blocks.size());
    int cols = 0;
    for (size_t i = 0; i < res.blocks.size(); ++i) {
      const BlockInfo& info = block_info_.at(res.blocks[i]);
      tangent_sizes[i] = tangentSize(info.ambient_size, info.manifold);
      cols += tangent_sizes[i];
    }
    Eigen::MatrixXd J(m, cols);
    int c = 0;
    for (size_t i = 0; i < res.blocks.size(); ++i) {
      if (block_info_.at(res.blocks[i]).manifold == BlockManifold::kPose) {
        Eigen::Matrix<double, kPoseSize, kPoseTangentSize, Eigen::RowMajor> plus_jacobian;
        pose_manifold.PlusJacobian(res.blocks[i], plus_jacobian.data());
        J.middleCols(c, kPoseTangentSize) = J_ambient[i] * plus_jacobian;
      } else {
        J.middleCols(c, tangent_sizes[i]) = J_ambient[i];
      }
      c += tangent_sizes[i];
    }
    if (!r.allFinite() || !J.allFinite()) {
      throw std::runtime_error("MarginalizationInfo: a cost function returned non-finite values");
    }
    if (res.loss) applyLoss(*res.loss, &r, &J);

    int ci = 0;
    for (size_t i = 0; i < res.blocks.size(); ++i) {
      const int col_i = column.at(res.blocks[i]);
      g.segment(col_i, tangent_sizes[i]) += J.middleCols(ci, tangent_sizes[i]).transpose() * r;
      int cj = 0;
      for (size_t j = 0; j < res.blocks.size(); ++j) {
        const int col_j = column.at(res.blocks[j]);
        H.block(col_i, col_j, tangent_sizes[i], tangent_sizes[j]) +=
            J.middleCols(ci, tangent_sizes[i]).transpose() * J.middleCols(cj, tangent_sizes[j]);
        cj += tangent_sizes[j];
      }
      ci += tangent_sizes[i];
    }
  }

  // Schur complement onto the kept blocks with a thresholded pseudo-inverse of H_dd.
  Eigen::MatrixXd H_star = H.bottomRightCorner(n_keep, n_keep);
  Eigen::VectorXd g_star = g.tail(n_keep);
  if (n_drop > 0) {
    const Eigen::MatrixXd H_dd = 0.5 * (H.topLeftCorner(n_drop, n_drop) + H.topLeftCorner(n_drop, n_drop).transpose());
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es_dd(H_dd);
    const Eigen::VectorXd s_dd = es_dd.eigenvalues();
    const double thr_dd = eigenThreshold(s_dd.maxCoeff(), options_);
    const Eigen::VectorXd s_dd_inv = (s_dd.array() > thr_dd).select(s_dd.cwiseInverse(), 0.0);
    const Eigen::MatrixXd H_dd_pinv = es_dd.eigenvectors() * s_dd_inv.asDiagonal() * es_dd.eigenvectors().transpose();
    const Eigen::MatrixXd H_kd = H.bottomLeftCorner(n_keep, n_drop);
    H_star -= H_kd * H_dd_pinv * H_kd.transpose();
    g_star -= H_kd * H_dd_pinv * g.head(n_drop);
  }
  H_star = 0.5 * (H_star + H_star.transpose());

  // Factor H* = J^T J on its numerically non-zero eigen-directions.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(H_star);
  const Eigen::VectorXd s = es.eigenvalues();
  const double thr = eigenThreshold(s.maxCoeff(), options_);
  std::vector<int> keep_dirs;
  for (int i = 0; i < s.size(); ++i) {
    if (s(i) > thr) keep_dirs.push_back(i);
  }
  last_discarded_ = n_keep - static_cast<int>(keep_dirs.size());
  if (keep_dirs.empty()) return nullptr;

  auto prior = std::make_shared<MarginalizationPrior>();
  const int rank = static_cast<int>(keep_dirs.size());
  prior->J.resize(rank, n_keep);
  prior->r0.resize(rank);
  for (int k = 0; k < rank; ++k) {
    const double sk = s(keep_dirs[k]);
    const Eigen::VectorXd v = es.eigenvectors().col(keep_dirs[k]);
    prior->J.row(k) = std::sqrt(sk) * v.transpose();
    prior->r0(k) = v.dot(g_star) / std::sqrt(sk);
  }
  for (double* b : kept) {
    const BlockInfo& info = block_info_.at(b);
    prior->blocks.push_back(b);
    prior->ambient_sizes.push_back(info.ambient_size);
    prior->manifolds.push_back(info.manifold);
    prior->x0.push_back(Eigen::Map<const Eigen::VectorXd>(b, info.ambient_size));
  }
  return prior;
}

}  // namespace vims
