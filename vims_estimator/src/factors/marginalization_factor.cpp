#include "vims_estimator/factors/marginalization_factor.h"

#include <stdexcept>

#include "vims_estimator/so3.h"
#include "vims_estimator/state_blocks.h"

namespace vims {

int tangentSize(int ambient_size, BlockManifold manifold) {
  return manifold == BlockManifold::kPose ? kPoseTangentSize : ambient_size;
}

Eigen::VectorXd MarginalizationPrior::difference(double const* const* values) const {
  Eigen::VectorXd dx(tangentDim());
  int col = 0;
  for (size_t b = 0; b < blocks.size(); ++b) {
    const int n = ambient_sizes[b];
    const Eigen::Map<const Eigen::VectorXd> x(values[b], n);
    if (manifolds[b] == BlockManifold::kPose) {
      PoseManifold().Minus(values[b], x0[b].data(), dx.data() + col);
      col += kPoseTangentSize;
    } else {
      dx.segment(col, n) = x - x0[b];
      col += n;
    }
  }
  return dx;
}

MarginalizationFactor::MarginalizationFactor(std::shared_ptr<const MarginalizationPrior> prior)
    : prior_(std::move(prior)) {
  if (!prior_) throw std::invalid_argument("MarginalizationFactor: null prior");
  if (prior_->rank() <= 0) throw std::invalid_argument("MarginalizationFactor: prior has rank 0");
  set_num_residuals(prior_->rank());
  for (int n : prior_->ambient_sizes) mutable_parameter_block_sizes()->push_back(n);
}

bool MarginalizationFactor::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
  const MarginalizationPrior& p = *prior_;
  const Eigen::VectorXd dx = p.difference(parameters);
  Eigen::Map<Eigen::VectorXd>(residuals, p.rank()) = p.J * dx + p.r0;
  if (!jacobians) return true;

  int col = 0;
  for (size_t b = 0; b < p.blocks.size(); ++b) {
    const int n = p.ambient_sizes[b];
    const int t = tangentSize(n, p.manifolds[b]);
    if (jacobians[b]) {
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Jb(jacobians[b], p.rank(), n);
      if (p.manifolds[b] == BlockManifold::kPose) {
        Jb = p.J.middleCols(col, t) * PoseManifold::minusJacobianAt(parameters[b], p.x0[b].data());
      } else {
        Jb = p.J.middleCols(col, t);
      }
    }
    col += t;
  }
  return true;
}

}  // namespace vims
