#pragma once
/// @file marginalization.h
/// @brief Marginalisation of parameter blocks out of the sliding window (Schur complement),
/// leaving a linear prior (MarginalizationPrior / MarginalizationFactor) on the kept blocks.
///
/// Procedure (docs/factors.md, "Marginalisation"):
/// 1. The caller declares every parameter block involved (address, ambient size, manifold) and
///    adds every residual block that touches at least one block to drop: cost function, loss,
///    blocks. These are typically fresh copies of the factors in the problem (the old prior's
///    MarginalizationFactor included).
/// 2. marginalize(drop) evaluates each residual block at the current values, converts its
///    Jacobians to the tangent space (J_tangent = J_ambient * PlusJacobian), applies the robust
///    loss (the same first-order correction Ceres applies: Triggs et al., "Bundle adjustment - a
///    modern synthesis", sec. 4.3), and accumulates H = sum J^T J and b = sum J^T r over the
///    tangent coordinates, ordered [dropped | kept].
/// 3. Schur complement: H* = H_kk - H_kd H_dd^+ H_dk, b* = b_k - H_kd H_dd^+ b_d, with H_dd^+ the
///    eigenvalue-thresholded pseudo-inverse (a dropped direction nothing constrains, e.g. a
///    feature depth seen from one pose, is simply not propagated).
/// 4. H* = V diag(s) V^T; eigen-directions with s <= threshold are dropped (rank deficiency: the
///    gauge directions of VIO - global position and yaw - carry no information and must not get
///    spurious noise-level information). With the kept s and V:
///    J = diag(sqrt(s)) V^T and r0 = diag(1/sqrt(s)) V^T b*, so that J^T J = H* and J^T r0 = b*
///    (restricted to the kept directions): the prior 1/2 |J dx + r0|^2 has the same gradient and
///    Hessian at x0 as the marginalised cost.
/// Threshold: s <= max(eigenvalue_absolute_threshold, eigenvalue_relative_threshold * s_max).

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <Eigen/Core>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "vims_common/config_reader.h"
#include "vims_estimator/factors/marginalization_factor.h"

namespace vims {

template <typename Options>
class OptionTable;

struct MarginalizationOptions {
  /// Eigenvalues below this fraction of the largest are treated as zero. Double-precision
  /// eigen-decomposition and the Schur complement's cancellation leave errors of about
  /// 1e-14..1e-12 of the largest eigenvalue in truly unobservable directions (the window's
  /// gauge); 1e-10 stays above that noise while keeping any direction with a real share of the
  /// information (a 1e5 ratio in standard deviation to the best-known one).
  double eigenvalue_relative_threshold = 1e-10;
  /// Absolute floor on eigenvalues [information units of the whitened residuals]: 1e-8 (VINS-Mono's
  /// epsilon) is a standard deviation of 1e4 in the tangent units - metres, radians, m/s - i.e. no
  /// information at all.
  double eigenvalue_absolute_threshold = 1e-8;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<MarginalizationOptions>& optionTable();

  /// Reads {eigenvalue_relative_threshold, eigenvalue_absolute_threshold}; unknown keys and values
  /// <= 0 throw ConfigError naming the key.
  static MarginalizationOptions fromReader(const ConfigReader& reader);
  std::string toYaml() const;
};

class MarginalizationInfo {
 public:
  explicit MarginalizationInfo(MarginalizationOptions options = MarginalizationOptions());

  /// Declares a parameter block. Every block of every added residual must be declared (so a pose
  /// block is never mistaken for a Euclidean one). Throws std::invalid_argument if the block was
  /// declared with another size or manifold, or a pose block's size is not 7.
  void addParameterBlock(double* block, int ambient_size, BlockManifold manifold);

  /// Adds a residual block. `loss` may be null. `cost` is evaluated in marginalize(); it must
  /// stay valid until then (shared ownership). Throws std::invalid_argument if a block is
  /// undeclared or its declared size differs from the cost function's.
  void addResidualBlock(std::shared_ptr<const ceres::CostFunction> cost,
                        std::shared_ptr<const ceres::LossFunction> loss, const std::vector<double*>& blocks);

  /// Linearises all residual blocks at the current block values and marginalises `drop`.
  /// Returns the prior on the kept blocks (ordered by first appearance in the residual blocks),
  /// or nullptr if no kept block remains or no information is left (rank 0).
  /// Throws std::invalid_argument if a drop block is not declared, or a residual block touches no
  /// dropped block (its information would be counted twice: it stays in the problem);
  /// std::runtime_error if a cost function fails to evaluate or returns non-finite values.
  std::shared_ptr<const MarginalizationPrior> marginalize(const std::vector<double*>& drop) const;

  /// Eigenvalues of H* discarded by the last marginalize() call (diagnostics).
  int lastDiscardedDirections() const { return last_discarded_; }

 private:
  struct BlockInfo {
    int ambient_size = 0;
    BlockManifold manifold = BlockManifold::kEuclidean;
  };
  struct ResidualInfo {
    std::shared_ptr<const ceres::CostFunction> cost;
    std::shared_ptr<const ceres::LossFunction> loss;
    std::vector<double*> blocks;
  };

  MarginalizationOptions options_;
  std::map<double*, BlockInfo> block_info_;
  std::vector<ResidualInfo> residuals_;
  mutable int last_discarded_ = 0;
};

}  // namespace vims
