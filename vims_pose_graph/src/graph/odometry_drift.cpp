#include "vims_pose_graph/odometry_drift.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <unordered_map>

#include "vims_pose_graph/angles.h"

namespace vims {

namespace {

/// Chains sharing more than this fraction of the longer chain's edges are one revisit event.
constexpr double kSameEventOverlap = 0.9;
/// chi-square with 4 degrees of freedom, 99.9 %: a chain's discrepancy beyond it is an outlier.
constexpr double kChiSquare4Dof999 = 18.467;
/// Grid of log10 of the multipliers: a coarse pass, then a fine one around its best point.
constexpr double kCoarseStep = 0.25;
constexpr double kFineStep = 0.025;

/// What one edge of a chain contributes to the chain's end-point discrepancy, in the frame of
/// the chain's first (match) node: position noise enters rotated by the yaw accumulated before
/// the edge, yaw noise turns the rest of the chain about the edge's end node.
struct ChainEdge {
  size_t edge = 0;              ///< index into the odometry edges
  double yaw_before = 0.0;      ///< accumulated yaw from the match to the edge's first node
  Eigen::Vector2d lever{0, 0};  ///< query position minus the edge's end node, horizontal
  double position_variance = 0.0;
  double yaw_variance = 0.0;
};

struct ChainSample {
  std::vector<ChainEdge> edges;  ///< ascending edge indices
  Eigen::Vector4d discrepancy = Eigen::Vector4d::Zero();
  Eigen::Vector4d loop_variance = Eigen::Vector4d::Ones();
  double length_m = 0.0;
};

/// Calls fn(edge of a, edge of b) for every odometry edge both chains contain.
template <typename Fn>
void forEachSharedEdge(const ChainSample& a, const ChainSample& b, Fn fn) {
  size_t i = 0, j = 0;
  while (i < a.edges.size() && j < b.edges.size()) {
    if (a.edges[i].edge < b.edges[j].edge) {
      ++i;
    } else if (b.edges[j].edge < a.edges[i].edge) {
      ++j;
    } else {
      fn(a.edges[i++], b.edges[j++]);
    }
  }
}

/// The 4 x 4 covariance block of two chains' discrepancies from the edges they share, split
/// into the part scaled by the position multiplier and the part scaled by the yaw multiplier.
void sharedEdgeCovariance(const ChainSample& a, const ChainSample& b, Eigen::Matrix4d* position, Eigen::Matrix4d* yaw) {
  position->setZero();
  yaw->setZero();
  forEachSharedEdge(a, b, [&](const ChainEdge& ea, const ChainEdge& eb) {
    // R(a) R(b)^T for the horizontal axes, 1 for z.
    const Eigen::Matrix2d R = rotationZ(ea.yaw_before - eb.yaw_before).topLeftCorner<2, 2>();
    position->topLeftCorner<2, 2>() += ea.position_variance * R;
    (*position)(2, 2) += ea.position_variance;
    const Eigen::Vector4d ga(-ea.lever.y(), ea.lever.x(), 0.0, 1.0);
    const Eigen::Vector4d gb(-eb.lever.y(), eb.lever.x(), 0.0, 1.0);
    *yaw += ea.yaw_variance * ga * gb.transpose();
  });
}

size_t sharedEdges(const ChainSample& a, const ChainSample& b) {
  size_t n = 0;
  forEachSharedEdge(a, b, [&](const ChainEdge&, const ChainEdge&) { ++n; });
  return n;
}

/// The chain of odometry edges from `match` to `query`, composed from the edges' measurements
/// (they come from one VIO frame, so this is the VIO's relative pose). Empty when none joins them.
std::optional<ChainSample> chainSample(const std::vector<SequentialEdge>& edges,
                                       const std::unordered_map<PoseGraphNodeId, size_t>& incoming,
                                       const LoopEdge& loop, const PoseGraphOptions& options) {
  if (loop.match >= loop.query) return std::nullopt;
  std::vector<size_t> path;
  for (PoseGraphNodeId node = loop.query; node != loop.match;) {
    const auto it = incoming.find(node);
    if (it == incoming.end() || edges[it->second].from < loop.match) return std::nullopt;
    path.push_back(it->second);
    node = edges[it->second].from;
  }
  std::reverse(path.begin(), path.end());
  ChainSample s;
  std::vector<Eigen::Vector2d> end_positions;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  double yaw = 0.0;
  for (size_t k : path) {
    const SequentialEdge& e = edges[k];
    const Eigen::Vector4d sigma = sequentialEdgeSqrtInformation(options, e.measurement).cwiseInverse();
    ChainEdge c;
    c.edge = k;
    c.yaw_before = yaw;
    c.position_variance = sigma[0] * sigma[0];
    c.yaw_variance = sigma[3] * sigma[3];
    p += rotationZ(yaw) * e.measurement.p_li_j;
    yaw += e.measurement.yaw_i_j;
    s.length_m += e.measurement.p_li_j.norm();
    s.edges.push_back(c);
    end_positions.push_back(p.head<2>());
  }
  for (size_t i = 0; i < s.edges.size(); ++i) s.edges[i].lever = p.head<2>() - end_positions[i];
  s.discrepancy.head<3>() = loop.measurement.p_li_j - p;
  s.discrepancy[3] = wrapAngle(loop.measurement.yaw_i_j - yaw);
  s.loop_variance = loop.sqrt_information.cwiseProduct(loop.sqrt_information).cwiseInverse();
  return s;
}

/// The chains' joint covariance, split as C(a_p, a_yaw) = a_p P + a_yaw Y + L.
struct JointCovariance {
  Eigen::MatrixXd position, yaw, loop;
  Eigen::VectorXd discrepancy;
};

JointCovariance jointCovariance(const std::vector<ChainSample>& chains) {
  const Eigen::Index n = static_cast<Eigen::Index>(chains.size());
  JointCovariance c;
  c.position = Eigen::MatrixXd::Zero(4 * n, 4 * n);
  c.yaw = Eigen::MatrixXd::Zero(4 * n, 4 * n);
  c.loop = Eigen::MatrixXd::Zero(4 * n, 4 * n);
  c.discrepancy.resize(4 * n);
  for (Eigen::Index a = 0; a < n; ++a) {
    c.discrepancy.segment<4>(4 * a) = chains[a].discrepancy;
    c.loop.block<4, 4>(4 * a, 4 * a) = chains[a].loop_variance.asDiagonal();
    for (Eigen::Index b = a; b < n; ++b) {
      Eigen::Matrix4d P, Y;
      sharedEdgeCovariance(chains[a], chains[b], &P, &Y);
      c.position.block<4, 4>(4 * a, 4 * b) = P;
      c.yaw.block<4, 4>(4 * a, 4 * b) = Y;
      c.position.block<4, 4>(4 * b, 4 * a) = P.transpose();
      c.yaw.block<4, 4>(4 * b, 4 * a) = Y.transpose();
    }
  }
  return c;
}

/// -2 log-likelihood (without the constant) of the discrepancies under the multipliers.
double negativeLogLikelihood(const JointCovariance& c, double a_p, double a_yaw) {
  const Eigen::MatrixXd C = a_p * c.position + a_yaw * c.yaw + c.loop;
  const Eigen::LLT<Eigen::MatrixXd> llt(C);
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  const Eigen::VectorXd w = llt.matrixL().solve(c.discrepancy);
  return w.squaredNorm() + 2.0 * llt.matrixLLT().diagonal().array().log().sum();
}

/// Grid search in log10 of both multipliers within the options' bounds: a coarse pass over the
/// whole range, then a fine one around its best point.
OdometryDriftScale fitScale(const JointCovariance& c, const PoseGraphOptions& options) {
  const double lo = std::log10(options.odometry_drift_scale_min);
  const double hi = std::log10(options.odometry_drift_scale_max);
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector2d best_log(0.0, 0.0);
  const auto search = [&](const Eigen::Vector2d& from, const Eigen::Vector2d& to, double step) {
    for (double lp = std::max(lo, from[0]); lp <= std::min(hi, to[0]) + 1e-9; lp += step)
      for (double ly = std::max(lo, from[1]); ly <= std::min(hi, to[1]) + 1e-9; ly += step) {
        const double v = negativeLogLikelihood(c, std::pow(10.0, lp), std::pow(10.0, ly));
        if (v < best) best = v, best_log = Eigen::Vector2d(lp, ly);
      }
  };
  search(Eigen::Vector2d::Constant(lo), Eigen::Vector2d::Constant(hi), kCoarseStep);
  const Eigen::Vector2d coarse = best_log;
  search(coarse.array() - kCoarseStep, coarse.array() + kCoarseStep, kFineStep);
  return OdometryDriftScale{std::pow(10.0, best_log[0]), std::pow(10.0, best_log[1])};
}

/// The joint covariance of the chains marked in `keep`.
JointCovariance restrictTo(const JointCovariance& c, const std::vector<bool>& keep) {
  std::vector<Eigen::Index> rows;
  for (size_t a = 0; a < keep.size(); ++a)
    if (keep[a])
      for (Eigen::Index k = 0; k < 4; ++k) rows.push_back(4 * static_cast<Eigen::Index>(a) + k);
  JointCovariance r;
  r.position = c.position(rows, rows);
  r.yaw = c.yaw(rows, rows);
  r.loop = c.loop(rows, rows);
  r.discrepancy = c.discrepancy(rows);
  return r;
}

/// Chains whose own discrepancy is within the chi-square bound under `scale`.
std::vector<bool> inlierChains(const JointCovariance& c, const OdometryDriftScale& scale) {
  const size_t n = static_cast<size_t>(c.discrepancy.size() / 4);
  std::vector<bool> in(n, false);
  for (size_t a = 0; a < n; ++a) {
    const Eigen::Index k = 4 * static_cast<Eigen::Index>(a);
    const Eigen::Matrix4d C =
        scale.position * c.position.block<4, 4>(k, k) + scale.yaw * c.yaw.block<4, 4>(k, k) + c.loop.block<4, 4>(k, k);
    const Eigen::Vector4d e = c.discrepancy.segment<4>(k);
    in[a] = e.dot(C.ldlt().solve(e)) <= kChiSquare4Dof999;
  }
  return in;
}

/// A start that one wrong loop cannot move: the median (in log) over the chains of each chain's
/// own fit. The joint fit is a Gaussian likelihood, which a single wrong chain would inflate
/// until it no longer looks wrong.
OdometryDriftScale medianOfSingleChainFits(const JointCovariance& c, const PoseGraphOptions& options) {
  const size_t n = static_cast<size_t>(c.discrepancy.size() / 4);
  std::vector<double> log_p, log_yaw;
  for (size_t a = 0; a < n; ++a) {
    std::vector<bool> one(n, false);
    one[a] = true;
    const OdometryDriftScale s = fitScale(restrictTo(c, one), options);
    log_p.push_back(std::log(s.position));
    log_yaw.push_back(std::log(s.yaw));
  }
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  return OdometryDriftScale{std::exp(median(log_p)), std::exp(median(log_yaw))};
}

size_t count(const std::vector<bool>& mask) { return static_cast<size_t>(std::count(mask.begin(), mask.end(), true)); }

}  // namespace

Eigen::Vector4d sequentialEdgeSqrtInformation(const PoseGraphOptions& options, const RelativePose4Dof& z,
                                              const OdometryDriftScale& scale) {
  const double d = z.p_li_j.norm();
  const double sigma_p = std::hypot(options.odometry_position_sigma_m, options.odometry_position_sigma_per_m * d) *
                         std::sqrt(scale.position);
  const double sigma_yaw =
      std::hypot(options.odometry_yaw_sigma_rad, options.odometry_yaw_sigma_per_m_rad * d) * std::sqrt(scale.yaw);
  return Eigen::Vector4d(1.0 / sigma_p, 1.0 / sigma_p, 1.0 / sigma_p, 1.0 / sigma_yaw);
}

namespace {

/// The loops' chains, one per revisit event (see fitOdometryDrift), with the ids of their loops.
struct SelectedChains {
  std::vector<ChainSample> chains;
  std::vector<LoopEdgeId> loop_ids;
  size_t loops_with_chain = 0;
};

SelectedChains selectChains(const std::vector<SequentialEdge>& odometry_edges, const std::vector<LoopEdge>& loops,
                            const PoseGraphOptions& options) {
  std::unordered_map<PoseGraphNodeId, size_t> incoming;
  for (size_t k = 0; k < odometry_edges.size(); ++k) incoming[odometry_edges[k].to] = k;
  SelectedChains out;
  for (const LoopEdge& loop : loops) {
    if (!loop.enabled) continue;
    std::optional<ChainSample> s = chainSample(odometry_edges, incoming, loop, options);
    if (!s || s->edges.empty()) continue;
    ++out.loops_with_chain;
    const bool same_event = std::any_of(out.chains.begin(), out.chains.end(), [&](const ChainSample& c) {
      return static_cast<double>(sharedEdges(c, *s)) >
             kSameEventOverlap * static_cast<double>(std::max(c.edges.size(), s->edges.size()));
    });
    if (same_event) continue;
    out.chains.push_back(std::move(*s));
    out.loop_ids.push_back(loop.id);
  }
  return out;
}

/// The robust fit: the chains within the chi-square bound under the median start are fitted
/// jointly; every chain is then tested again under that fit, and a changed set is fitted once more.
OdometryDriftFit fitChains(const std::vector<ChainSample>& chains, size_t loops_with_chain,
                           const PoseGraphOptions& options) {
  OdometryDriftFit fit;
  fit.loops_with_chain = loops_with_chain;
  const size_t min_chains = static_cast<size_t>(options.odometry_drift_min_chains);
  if (chains.size() < min_chains) return fit;
  const JointCovariance all = jointCovariance(chains);
  const std::vector<bool> start_inliers = inlierChains(all, medianOfSingleChainFits(all, options));
  if (count(start_inliers) < min_chains) return fit;
  OdometryDriftScale scale = fitScale(restrictTo(all, start_inliers), options);
  const std::vector<bool> inliers = inlierChains(all, scale);
  if (count(inliers) < min_chains) return fit;
  if (inliers != start_inliers) scale = fitScale(restrictTo(all, inliers), options);
  fit.fitted = true;
  fit.scale = scale;
  fit.chains_used = count(inliers);
  fit.chains_rejected = chains.size() - fit.chains_used;
  for (size_t a = 0; a < chains.size(); ++a)
    if (inliers[a]) fit.mean_chain_length_m += chains[a].length_m / static_cast<double>(fit.chains_used);
  return fit;
}

}  // namespace

OdometryDriftFit fitOdometryDrift(const std::vector<SequentialEdge>& odometry_edges, const std::vector<LoopEdge>& loops,
                                  const PoseGraphOptions& options) {
  const SelectedChains selected = selectChains(odometry_edges, loops, options);
  return fitChains(selected.chains, selected.loops_with_chain, options);
}

const OdometryDriftFit& OdometryDriftEstimator::update(const std::vector<SequentialEdge>& odometry_edges,
                                                       const std::vector<LoopEdge>& loops) {
  SelectedChains selected = selectChains(odometry_edges, loops, options_);
  if (selected.loop_ids != chain_loops_) {
    chain_loops_ = selected.loop_ids;
    fit_ = fitChains(selected.chains, selected.loops_with_chain, options_);
  }
  fit_.loops_with_chain = selected.loops_with_chain;
  return fit_;
}

}  // namespace vims
