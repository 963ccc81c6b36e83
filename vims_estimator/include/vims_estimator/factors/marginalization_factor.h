#pragma once
/// @file marginalization_factor.h
/// @brief The linear prior that marginalisation leaves on the kept blocks, and its Ceres factor.
///
/// A MarginalizationPrior (built by MarginalizationInfo, marginalization.h) is the Gaussian
///   r(x) = J (x (-) x0) + r0,       cost 1/2 |r|^2
/// on the kept blocks x = (x_1 .. x_n), linearised at x0. (-) is the block's manifold difference:
///   Euclidean block: x - x0
///   pose block:      [p - p0, Log(q0^{-1} q)]            (PoseManifold::Minus)
/// J has one row per retained eigen-direction (rank rows) and one column per tangent dimension.
/// Jacobians for Ceres (ambient, per block): J_b * D_b with D_b = I (Euclidean) or
/// PoseManifold::minusJacobianAt(x_b, x0_b) = [I 0; 0 Jr^{-1}(Log(q0^{-1} q)) lift(q)]; the
/// Jr^{-1} factor makes the Jacobian exact away from x0 (VINS-Mono drops it).

#include <ceres/cost_function.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

namespace vims {

/// How a parameter block is perturbed (its ceres::Manifold in the problem).
enum class BlockManifold {
  kEuclidean,  ///< no manifold: tangent = ambient
  kPose,       ///< PoseManifold (7 ambient, 6 tangent)
};

/// Tangent size of a block of the given ambient size and manifold.
int tangentSize(int ambient_size, BlockManifold manifold);

/// The result of marginalisation: a linear prior on the kept blocks.
struct MarginalizationPrior {
  /// Kept blocks in factor order: the addresses at marginalisation time. After the window
  /// shifts, add the factor with the blocks that now hold these states, in this order.
  std::vector<double*> blocks;
  std::vector<int> ambient_sizes;
  std::vector<BlockManifold> manifolds;
  std::vector<Eigen::VectorXd> x0;  ///< linearisation point of each block (ambient values)
  Eigen::MatrixXd J;                ///< rank x tangentDim()
  Eigen::VectorXd r0;               ///< rank

  int rank() const { return static_cast<int>(r0.size()); }
  int tangentDim() const { return static_cast<int>(J.cols()); }

  /// The stacked x (-) x0 for block values `values` (same order as `blocks`).
  Eigen::VectorXd difference(double const* const* values) const;
};

/// r = J (x (-) x0) + r0 on the kept blocks (parameter blocks in MarginalizationPrior::blocks order,
/// ambient sizes). The number of residuals is the prior's rank (> 0; MarginalizationInfo does not
/// produce an empty prior).
class MarginalizationFactor : public ceres::CostFunction {
 public:
  /// Throws std::invalid_argument if prior is null or has rank 0.
  explicit MarginalizationFactor(std::shared_ptr<const MarginalizationPrior> prior);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

  const MarginalizationPrior& prior() const { return *prior_; }

 private:
  std::shared_ptr<const MarginalizationPrior> prior_;
};

}  // namespace vims
