// Marginalisation: Schur complement against dense linear algebra, exactness on linear problems,
// stationarity of the reduced problem at the full optimum on a nonlinear pose graph, rank
// deficiency, and the robust-loss correction against Ceres' own.
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <random>

#include "test_utils.h"
#include "vims_estimator/factors/marginalization_factor.h"
#include "vims_estimator/factors/pose_prior_factor.h"
#include "vims_estimator/factors/relative_pose_factor.h"
#include "vims_estimator/marginalization.h"

namespace vims {
namespace {

using test::poseBlock;
using test::randomRotation;
using test::randomVector;

/// r = A [x_1; ...; x_n] + c over Euclidean blocks (a linear residual for exactness tests).
class LinearCost : public ceres::CostFunction {
 public:
  LinearCost(Eigen::MatrixXd A, Eigen::VectorXd c, const std::vector<int>& sizes) : A_(std::move(A)), c_(std::move(c)) {
    set_num_residuals(static_cast<int>(A_.rows()));
    for (int s : sizes) mutable_parameter_block_sizes()->push_back(s);
  }
  bool Evaluate(double const* const* x, double* residuals, double** jacobians) const override {
    Eigen::Map<Eigen::VectorXd> r(residuals, A_.rows());
    r = c_;
    int col = 0;
    for (size_t b = 0; b < parameter_block_sizes().size(); ++b) {
      const int n = parameter_block_sizes()[b];
      r += A_.middleCols(col, n) * Eigen::Map<const Eigen::VectorXd>(x[b], n);
      if (jacobians && jacobians[b]) {
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[b], A_.rows(), n) =
            A_.middleCols(col, n);
      }
      col += n;
    }
    return true;
  }

 private:
  Eigen::MatrixXd A_;
  Eigen::VectorXd c_;
};

// Linear least squares over x = [d (3), k1 (2), k2 (4)], residuals that touch d. The prior must
// equal the dense Schur complement, and minimising (prior + remaining residuals) must give the
// same kept values as the full problem - exactly, for any linearisation point.
TEST(Marginalization, SchurComplementIsExactOnLinearProblems) {
  std::mt19937 rng(1);
  std::vector<double> d(3), k1(2), k2(4);
  for (auto* v : {&d, &k1, &k2})
    for (double& x : *v) x = randomVector(rng, 1.0).x();

  const Eigen::MatrixXd A1 = Eigen::MatrixXd::Random(5, 5);  // over [d, k1]
  const Eigen::VectorXd c1 = Eigen::VectorXd::Random(5);
  const Eigen::MatrixXd A2 = Eigen::MatrixXd::Random(6, 7);  // over [d, k2]
  const Eigen::VectorXd c2 = Eigen::VectorXd::Random(6);
  const Eigen::MatrixXd A3 = Eigen::MatrixXd::Random(7, 6);  // over [k1, k2], not marginalised
  const Eigen::VectorXd c3 = Eigen::VectorXd::Random(7);
  auto f1 = std::make_shared<LinearCost>(A1, c1, std::vector<int>{3, 2});
  auto f2 = std::make_shared<LinearCost>(A2, c2, std::vector<int>{3, 4});

  MarginalizationInfo info;
  info.addParameterBlock(d.data(), 3, BlockManifold::kEuclidean);
  info.addParameterBlock(k1.data(), 2, BlockManifold::kEuclidean);
  info.addParameterBlock(k2.data(), 4, BlockManifold::kEuclidean);
  info.addResidualBlock(f1, nullptr, {d.data(), k1.data()});
  info.addResidualBlock(f2, nullptr, {d.data(), k2.data()});
  const auto prior = info.marginalize({d.data()});
  ASSERT_TRUE(prior);
  ASSERT_EQ(prior->blocks.size(), 2u);
  EXPECT_EQ(prior->blocks[0], k1.data());
  EXPECT_EQ(prior->rank(), 6);

  // Dense reference in the order [d, k1, k2].
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(11, 9);
  J.block(0, 0, 5, 5) = A1;
  J.block(5, 0, 6, 3) = A2.leftCols(3);
  J.block(5, 5, 6, 4) = A2.rightCols(4);
  Eigen::VectorXd x(9);
  x << Eigen::Map<Eigen::VectorXd>(d.data(), 3), Eigen::Map<Eigen::VectorXd>(k1.data(), 2),
      Eigen::Map<Eigen::VectorXd>(k2.data(), 4);
  Eigen::VectorXd r(11);
  r << A1 * x.head(5) + c1, A2.leftCols(3) * x.head(3) + A2.rightCols(4) * x.tail(4) + c2;
  const Eigen::MatrixXd H = J.transpose() * J;
  const Eigen::VectorXd g = J.transpose() * r;
  const Eigen::MatrixXd Hdd_inv = H.topLeftCorner(3, 3).inverse();
  const Eigen::MatrixXd H_star =
      H.bottomRightCorner(6, 6) - H.bottomLeftCorner(6, 3) * Hdd_inv * H.topRightCorner(3, 6);
  const Eigen::VectorXd g_star = g.tail(6) - H.bottomLeftCorner(6, 3) * Hdd_inv * g.head(3);
  EXPECT_LT((prior->J.transpose() * prior->J - H_star).norm(), 1e-10 * H_star.norm());
  EXPECT_LT((prior->J.transpose() * prior->r0 - g_star).norm(), 1e-10 * std::max(1.0, g_star.norm()));

  // Full problem vs reduced problem.
  auto solve_kept = [&](bool reduced) {
    std::vector<double> dd = d, kk1 = k1, kk2 = k2;
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    LinearCost f3(A3, c3, {2, 4});
    MarginalizationFactor fm(prior);
    problem.AddResidualBlock(&f3, nullptr, kk1.data(), kk2.data());
    if (reduced) {
      problem.AddResidualBlock(&fm, nullptr, kk1.data(), kk2.data());
    } else {
      problem.AddResidualBlock(f1.get(), nullptr, dd.data(), kk1.data());
      problem.AddResidualBlock(f2.get(), nullptr, dd.data(), kk2.data());
    }
    ceres::Solver::Options o;
    o.linear_solver_type = ceres::DENSE_QR;
    o.function_tolerance = o.gradient_tolerance = 1e-16;
    o.parameter_tolerance = 1e-14;
    ceres::Solver::Summary s;
    ceres::Solve(o, &problem, &s);
    Eigen::VectorXd out(6);
    out << Eigen::Map<Eigen::VectorXd>(kk1.data(), 2), Eigen::Map<Eigen::VectorXd>(kk2.data(), 4);
    return out;
  };
  EXPECT_LT((solve_kept(true) - solve_kept(false)).norm(), 1e-8);
}

// A nonlinear pose graph (pose prior, relative-pose edges) solved to its optimum; marginalising
// the first pose there leaves a reduced problem whose optimum is the same (the prior reproduces
// the marginalised cost's gradient and Hessian at the linearisation point), also when started
// from a perturbed state.
TEST(Marginalization, ReducedPoseGraphKeepsTheOptimum) {
  std::mt19937 rng(5);
  const int n = 4;
  std::vector<Eigen::Isometry3d> truth(n);
  for (int i = 0; i < n; ++i) {
    truth[i] = Eigen::Isometry3d::Identity();
    truth[i].linear() = randomRotation(rng, 1.5).toRotationMatrix();
    truth[i].translation() = randomVector(rng, 3.0);
  }
  struct Edge {
    int i, j;
    std::shared_ptr<RelativePoseFactor> factor;
  };
  std::vector<Edge> edges;
  for (auto [i, j] : std::vector<std::pair<int, int>>{{0, 1}, {1, 2}, {2, 3}, {0, 2}, {1, 3}, {0, 3}}) {
    const Eigen::Isometry3d T_ij = truth[i].inverse() * truth[j];
    // Noisy measurements so the optimum has non-zero residuals.
    const Eigen::Vector3d p = T_ij.translation() + randomVector(rng, 0.05);
    const Eigen::Quaterniond q = Eigen::Quaterniond(T_ij.linear()) * so3::exp(randomVector(rng, 0.03));
    Matrix6d S = Matrix6d::Identity() * 10.0;
    S(1, 5) = 2.0;
    edges.push_back({i, j, std::make_shared<RelativePoseFactor>(p, q, S)});
  }
  auto prior0 = std::make_shared<PosePriorFactor>(truth[0].translation(), Eigen::Quaterniond(truth[0].linear()),
                                                  Matrix6d::Identity() * 100.0);

  PoseManifold manifold;
  auto solve = [&](std::vector<std::vector<double>>& x, bool reduced, std::shared_ptr<const MarginalizationPrior> mp) {
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    for (auto& b : x) problem.AddParameterBlock(b.data(), 7, &manifold);
    std::unique_ptr<MarginalizationFactor> fm;
    if (reduced) {
      fm = std::make_unique<MarginalizationFactor>(mp);
      std::vector<double*> blocks;
      for (double* b : mp->blocks) blocks.push_back(b);
      problem.AddResidualBlock(fm.get(), nullptr, blocks);
    } else {
      problem.AddResidualBlock(prior0.get(), nullptr, x[0].data());
    }
    for (const Edge& e : edges) {
      if (reduced && e.i == 0) continue;
      problem.AddResidualBlock(e.factor.get(), nullptr, x[e.i].data(), x[e.j].data());
    }
    if (reduced) problem.SetParameterBlockConstant(x[0].data());  // not in any factor any more
    ceres::Solver::Options o;
    o.linear_solver_type = ceres::DENSE_QR;
    o.function_tolerance = o.gradient_tolerance = 1e-16;
    o.parameter_tolerance = 1e-14;
    o.max_num_iterations = 200;
    ceres::Solver::Summary s;
    ceres::Solve(o, &problem, &s);
    EXPECT_TRUE(s.IsSolutionUsable());
  };

  std::vector<std::vector<double>> x;
  for (int i = 0; i < n; ++i) {
    Eigen::Isometry3d T = truth[i];
    T.translation() += randomVector(rng, 0.3);
    T.linear() = T.linear() * randomRotation(rng, 0.2).toRotationMatrix();
    x.push_back(poseBlock(T));
  }
  solve(x, false, nullptr);
  const std::vector<std::vector<double>> optimum = x;

  MarginalizationInfo info;
  for (auto& b : x) info.addParameterBlock(b.data(), 7, BlockManifold::kPose);
  info.addResidualBlock(prior0, nullptr, {x[0].data()});
  for (const Edge& e : edges) {
    if (e.i == 0) info.addResidualBlock(e.factor, nullptr, {x[e.i].data(), x[e.j].data()});
  }
  const auto mp = info.marginalize({x[0].data()});
  ASSERT_TRUE(mp);
  EXPECT_EQ(mp->rank(), 18);  // 3 kept poses, fully informed by the prior through the edges
  EXPECT_EQ(info.lastDiscardedDirections(), 0);

  // Perturb the kept poses and re-solve the reduced problem.
  for (int i = 1; i < n; ++i) {
    Eigen::Matrix<double, 6, 1> d;
    d << randomVector(rng, 0.2), randomVector(rng, 0.1);
    std::vector<double> moved(7);
    manifold.Plus(x[i].data(), d.data(), moved.data());
    x[i] = moved;
  }
  solve(x, true, mp);
  for (int i = 1; i < n; ++i) {
    Eigen::Matrix<double, 6, 1> diff;
    manifold.Minus(x[i].data(), optimum[i].data(), diff.data());
    EXPECT_LT(diff.norm(), 1e-7) << "pose " << i;
  }
}

// Rank deficiency: a dropped pose tied to a kept pose by a relative edge only carries no
// information about the kept pose (nullptr, no NaN); with a position+yaw prior on the dropped pose
// the kept pose gets exactly 4 informed directions.
TEST(Marginalization, RankDeficiencyIsThresholdedNotInverted) {
  std::mt19937 rng(3);
  std::vector<double> a = poseBlock(randomVector(rng, 1.0), randomRotation(rng, 0.5));
  std::vector<double> b = poseBlock(randomVector(rng, 1.0), randomRotation(rng, 0.5));
  auto edge = std::make_shared<RelativePoseFactor>(Eigen::Vector3d(1, 0, 0), Eigen::Quaterniond::Identity(),
                                                   Matrix6d::Identity() * 5.0);
  {
    MarginalizationInfo info;
    info.addParameterBlock(a.data(), 7, BlockManifold::kPose);
    info.addParameterBlock(b.data(), 7, BlockManifold::kPose);
    info.addResidualBlock(edge, nullptr, {a.data(), b.data()});
    EXPECT_EQ(info.marginalize({a.data()}), nullptr);
    EXPECT_EQ(info.lastDiscardedDirections(), 6);
  }
  {
    MarginalizationInfo info;
    info.addParameterBlock(a.data(), 7, BlockManifold::kPose);
    info.addParameterBlock(b.data(), 7, BlockManifold::kPose);
    info.addResidualBlock(edge, nullptr, {a.data(), b.data()});
    info.addResidualBlock(std::make_shared<PosePriorFactor>(Eigen::Vector3d::Zero(), Eigen::Quaterniond::Identity(),
                                                            PosePriorFactor::positionYawSqrtInformation(0.1, 0.05)),
                          nullptr, {a.data()});
    const auto prior = info.marginalize({a.data()});
    ASSERT_TRUE(prior);
    EXPECT_EQ(prior->rank(), 4);
    EXPECT_EQ(info.lastDiscardedDirections(), 2);
    EXPECT_TRUE(prior->J.allFinite());
    EXPECT_TRUE(prior->r0.allFinite());
  }
}

TEST(Marginalization, MisuseIsRejected) {
  std::vector<double> a(3, 0.0), b(3, 0.0), c(3, 0.0);
  auto f =
      std::make_shared<LinearCost>(Eigen::MatrixXd::Identity(3, 6), Eigen::VectorXd::Zero(3), std::vector<int>{3, 3});
  MarginalizationInfo info;
  info.addParameterBlock(a.data(), 3, BlockManifold::kEuclidean);
  EXPECT_THROW(info.addResidualBlock(f, nullptr, {a.data(), b.data()}), std::invalid_argument);  // b undeclared
  info.addParameterBlock(b.data(), 3, BlockManifold::kEuclidean);
  EXPECT_THROW(info.addParameterBlock(b.data(), 7, BlockManifold::kPose), std::invalid_argument);
  info.addParameterBlock(c.data(), 3, BlockManifold::kEuclidean);
  info.addResidualBlock(f, nullptr, {a.data(), b.data()});
  EXPECT_THROW(info.marginalize({c.data()}), std::invalid_argument);  // the residual touches no dropped block
  EXPECT_THROW(info.addParameterBlock(c.data(), 3, BlockManifold::kPose), std::invalid_argument);
}

// With a robust loss, the linearised prior reproduces what Ceres itself optimises: the
// loss-corrected gradient and Gauss-Newton Hessian (compared with ceres::Problem::Evaluate).
TEST(Marginalization, RobustLossLinearisationMatchesCeres) {
  for (double offset : {0.3, 4.0}) {  // inlier and outlier region of the Huber/Cauchy losses
    std::vector<double> k = {offset, -0.5 * offset};
    std::vector<double> d = {0.2};
    // Residual over [k (2), d (1)] that does not couple d (so the Schur term vanishes) and a
    // separate residual on d that keeps H_dd invertible.
    Eigen::MatrixXd A(2, 3);
    A << 1.0, 0.5, 0.0, -0.3, 2.0, 0.0;
    auto robust = std::make_shared<LinearCost>(A, Eigen::Vector2d(0.1, -0.2), std::vector<int>{2, 1});
    auto anchor_d =
        std::make_shared<LinearCost>(Eigen::MatrixXd::Identity(1, 1), Eigen::VectorXd::Zero(1), std::vector<int>{1});
    for (int which = 0; which < 2; ++which) {
      std::shared_ptr<ceres::LossFunction> loss =
          which == 0 ? std::shared_ptr<ceres::LossFunction>(new ceres::HuberLoss(1.0))
                     : std::shared_ptr<ceres::LossFunction>(new ceres::CauchyLoss(1.0));
      MarginalizationInfo info;
      info.addParameterBlock(k.data(), 2, BlockManifold::kEuclidean);
      info.addParameterBlock(d.data(), 1, BlockManifold::kEuclidean);
      info.addResidualBlock(robust, loss, {k.data(), d.data()});
      info.addResidualBlock(anchor_d, nullptr, {d.data()});
      const auto prior = info.marginalize({d.data()});
      ASSERT_TRUE(prior);

      ceres::Problem::Options po;
      po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
      po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
      ceres::Problem problem(po);
      problem.AddResidualBlock(robust.get(), loss.get(), k.data(), d.data());
      problem.SetParameterBlockConstant(d.data());
      std::vector<double> gradient;
      ceres::CRSMatrix crs;
      problem.Evaluate(ceres::Problem::EvaluateOptions(), nullptr, nullptr, &gradient, &crs);
      Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
      for (int r = 0; r < crs.num_rows; ++r)
        for (int i = crs.rows[r]; i < crs.rows[r + 1]; ++i) J(r, crs.cols[i]) = crs.values[i];
      // Ceres reports the constant block d as zero columns after k's two (k was added first).
      ASSERT_EQ(J.cols(), 3);
      const Eigen::MatrixXd J_k = J.leftCols(2);
      const Eigen::Vector2d g_ceres(gradient[0], gradient[1]);
      EXPECT_GT(g_ceres.norm(), 0.1);
      EXPECT_LT((prior->J.transpose() * prior->r0 - g_ceres).norm(), 1e-10) << offset << " loss " << which;
      EXPECT_LT((prior->J.transpose() * prior->J - J_k.transpose() * J_k).norm(), 1e-10) << offset << " loss " << which;
    }
  }
}

}  // namespace
}  // namespace vims
