#include "vims_pose_graph/pose_graph.h"

#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "vims_common/option_table.h"
#include "vims_pose_graph/angles.h"
#include "vims_pose_graph/odometry_drift.h"

namespace vims {

namespace {
constexpr double kDeg = M_PI / 180.0;
constexpr const char* kComponent = "pose_graph";

std::unique_ptr<ceres::LossFunction> makeLoss(RobustLoss loss, double scale) {
  // Ceres' scale `a` is in units of the whitened residual norm: quadratic below a sigmas.
  switch (loss) {
    case RobustLoss::kHuber:
      return std::make_unique<ceres::HuberLoss>(scale);
    case RobustLoss::kCauchy:
      return std::make_unique<ceres::CauchyLoss>(scale);
    case RobustLoss::kNone:
      break;
  }
  return nullptr;
}

bool isRotation(const Eigen::Matrix3d& R) {
  return R.allFinite() && (R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
         R.determinant() > 0.0;
}

bool isValidPose(const Eigen::Isometry3d& T) { return T.translation().allFinite() && isRotation(T.linear()); }

/// Whether the Cauchy solve needs the convex Huber stage first: some new loop (id >=
/// first_new_loop_id) that the solve may move starts further than the loss scale from its
/// measurement, where Cauchy is not convex. Loops inside the scale (a burst of loops after the
/// first one closed the drift, or a solve without new loops) start in Cauchy's convex region.
bool needsConvexStage(const PoseGraphSnapshot& s, size_t first_free) {
  for (const LoopEdge& e : s.loop_edges) {
    if (e.id < s.first_new_loop_id || (e.match < first_free && e.query < first_free)) continue;
    const Eigen::Vector4d r = relativePose4DofResidual(s.nodes[e.match].p_w_b, s.nodes[e.match].yaw_w_b,
                                                       s.nodes[e.query].p_w_b, s.nodes[e.query].yaw_w_b, e.measurement);
    if (e.sqrt_information.cwiseProduct(r).norm() > s.options.loop_loss_scale) return true;
  }
  return false;
}
}  // namespace

std::string toString(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kHuber:
      return "huber";
    case RobustLoss::kCauchy:
      return "cauchy";
    case RobustLoss::kNone:
      break;
  }
  return "none";
}

RobustLoss robustLossFromString(const std::string& name) {
  if (name == "none") return RobustLoss::kNone;
  if (name == "huber") return RobustLoss::kHuber;
  if (name == "cauchy") return RobustLoss::kCauchy;
  throw std::invalid_argument("unknown robust loss '" + name + "' (expected none, huber or cauchy)");
}

// ---------------------------------------------------------------------------------------------
// Options
// ---------------------------------------------------------------------------------------------

const OptionTable<PoseGraphOptions>& PoseGraphOptions::optionTable() {
  using O = PoseGraphOptions;
  const std::vector<RobustLoss> losses = {RobustLoss::kNone, RobustLoss::kHuber, RobustLoss::kCauchy};
  const auto loss_name = [](RobustLoss loss) { return toString(loss); };
  static const auto table =
      OptionTable<O>()
          .number("odometry_position_sigma_m", &O::odometry_position_sigma_m, Bounds::positive())
          .number("odometry_position_sigma_per_m", &O::odometry_position_sigma_per_m, Bounds::nonNegative())
          .scaledNumber("odometry_yaw_sigma_deg", &O::odometry_yaw_sigma_rad, kDeg, Bounds::positive())
          .scaledNumber("odometry_yaw_sigma_per_m_deg", &O::odometry_yaw_sigma_per_m_rad, kDeg, Bounds::nonNegative())
          .flag("learn_odometry_drift", &O::learn_odometry_drift)
          .integer("odometry_drift_min_chains", &O::odometry_drift_min_chains, Bounds::closed(1, 1000))
          .number("odometry_drift_scale_min", &O::odometry_drift_scale_min, Bounds::closed(1e-6, 1.0))
          .number("odometry_drift_scale_max", &O::odometry_drift_scale_max, Bounds::closed(1.0, 1e6))
          .number("loop_position_sigma_m", &O::loop_position_sigma_m, Bounds::positive())
          .scaledNumber("loop_yaw_sigma_deg", &O::loop_yaw_sigma_rad, kDeg, Bounds::positive())
          .flag("loop_sigma_from_inliers", &O::loop_sigma_from_inliers)
          .number("loop_position_sigma_floor_m", &O::loop_position_sigma_floor_m, Bounds::positive())
          .scaledNumber("loop_yaw_sigma_floor_deg", &O::loop_yaw_sigma_floor_rad, kDeg, Bounds::positive())
          .choice<RobustLoss>("loop_loss", &O::loop_loss, losses, loss_name)
          .number("loop_loss_scale", &O::loop_loss_scale, Bounds::positive())
          .scaledNumber("mag_yaw_sigma_deg", &O::mag_yaw_sigma_rad, kDeg, Bounds::closed(1e-6, 180.0))
          .choice<RobustLoss>("mag_loss", &O::mag_loss, losses, loss_name)
          .number("mag_loss_scale", &O::mag_loss_scale, Bounds::positive())
          .number("mag_min_horizontal_field_tesla", &O::mag_min_horizontal_field_tesla, Bounds::closed(0.0, 1e-3))
          .integer("max_iterations", &O::max_iterations, Bounds::closed(1, 10000))
          .number("max_solver_time_s", &O::max_solver_time_s, Bounds::nonNegative())
          .integer("num_threads", &O::num_threads, Bounds::closed(1, 64))
          .number("function_tolerance", &O::function_tolerance, Bounds::closed(1e-12, 0.1))
          .number("online_function_tolerance", &O::online_function_tolerance, Bounds::closed(1e-12, 0.1))
          .flag("loop_solve_from_earliest_node", &O::loop_solve_from_earliest_node)
          .integer("window_keyframes", &O::window_keyframes, Bounds::closed(0, 100000000))
          .number("loop_local_solve_max_sigmas", &O::loop_local_solve_max_sigmas, Bounds::nonNegative())
          .number("depth_sigma_m", &O::depth_sigma_m, Bounds::positive());
  return table;
}

PoseGraphOptions PoseGraphOptions::fromReader(const ConfigReader& reader) {
  return readOptions<PoseGraphOptions>(reader);
}

void PoseGraphOptions::validate() const { throwIfInvalid(optionTable(), *this, "PoseGraphOptions"); }

std::string PoseGraphOptions::toYaml() const { return optionTable().toYaml(*this); }

// ---------------------------------------------------------------------------------------------
// Graph
// ---------------------------------------------------------------------------------------------

Eigen::Isometry3d PoseGraphNode::T_w_b() const {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rotationFromYawPitchRoll(yaw_w_b, pitch, roll);
  T.translation() = p_w_b;
  return T;
}

PoseGraph4Dof::PoseGraph4Dof(const PoseGraphOptions& options, const MagnetometerCalibration& magnetometer,
                             LoggerPtr logger)
    : options_(options),
      north_enu_(magneticNorthEnu(magnetometer.declination_deg * kDeg)),
      R_b_m_(magnetometer.T_b_m.linear()),
      logger_(logger ? std::move(logger) : Logger::nullLogger()) {
  options_.validate();
  if (!std::isfinite(magnetometer.declination_deg) || !isRotation(R_b_m_))
    throw std::invalid_argument("PoseGraph4Dof: invalid magnetometer calibration (declination or T_b_m)");
}

void PoseGraph4Dof::checkNode(PoseGraphNodeId id, const char* what) const {
  if (id >= nodes_.size())
    throw std::invalid_argument(std::string("PoseGraph4Dof: ") + what + ": unknown node " + std::to_string(id) +
                                " (graph has " + std::to_string(nodes_.size()) + ")");
}

PoseGraphNodeId PoseGraph4Dof::addNode(double t, const Eigen::Isometry3d& T_odom_b) {
  if (!std::isfinite(t) || !isValidPose(T_odom_b))
    throw std::invalid_argument("PoseGraph4Dof::addNode: non-finite time or invalid VIO pose");
  if (!nodes_.empty() && t < nodes_.back().t)
    throw std::invalid_argument("PoseGraph4Dof::addNode: time goes backwards (" + std::to_string(t) + " < " +
                                std::to_string(nodes_.back().t) + ")");
  const YawPitchRoll ypr = yawPitchRollFromRotation(T_odom_b.linear());
  PoseGraphNode n;
  n.t = t;
  n.T_odom_b = T_odom_b;
  n.pitch = ypr.pitch;
  n.roll = ypr.roll;
  // Start from the latest drift correction, so a new keyframe lands where the corrected map
  // expects it instead of where the drifting VIO puts it.
  const Eigen::Isometry3d T_map_odom_latest = T_map_odom();
  n.p_w_b = T_map_odom_latest * T_odom_b.translation();
  n.yaw_w_b = wrapAngle(ypr.yaw + yawPitchRollFromRotation(T_map_odom_latest.linear()).yaw);
  nodes_.push_back(n);
  return static_cast<PoseGraphNodeId>(nodes_.size() - 1);
}

void PoseGraph4Dof::addSequentialEdge(PoseGraphNodeId from, PoseGraphNodeId to) {
  checkNode(from, "addSequentialEdge");
  checkNode(to, "addSequentialEdge");
  if (from == to) throw std::invalid_argument("PoseGraph4Dof::addSequentialEdge: from == to");
  SequentialEdge e;
  e.from = from;
  e.to = to;
  e.measurement = relativePose4DofFromPoses(nodes_[from].T_odom_b, nodes_[to].T_odom_b);
  e.sqrt_information = sequentialEdgeSqrtInformation(options_, e.measurement);
  sequential_edges_.push_back(e);
}

LoopEdgeId PoseGraph4Dof::addLoopEdge(PoseGraphNodeId match, PoseGraphNodeId query,
                                      const Eigen::Isometry3d& T_match_query) {
  checkNode(match, "addLoopEdge");
  checkNode(query, "addLoopEdge");
  if (match == query) throw std::invalid_argument("PoseGraph4Dof::addLoopEdge: match == query");
  if (!isValidPose(T_match_query)) throw std::invalid_argument("PoseGraph4Dof::addLoopEdge: invalid relative pose");
  LoopEdge e;
  e.id = next_loop_id_++;
  e.match = match;
  e.query = query;
  e.T_match_query = T_match_query;
  e.measurement = relativePose4DofFromRelative(T_match_query, nodes_[match].pitch, nodes_[match].roll);
  const double ip = 1.0 / options_.loop_position_sigma_m;
  e.sqrt_information << ip, ip, ip, 1.0 / options_.loop_yaw_sigma_rad;
  loop_edges_.push_back(e);
  return e.id;
}

bool PoseGraph4Dof::setLoopEdgeEnabled(LoopEdgeId id, bool enabled) {
  auto it = std::find_if(loop_edges_.begin(), loop_edges_.end(), [id](const LoopEdge& e) { return e.id == id; });
  if (it == loop_edges_.end()) return false;
  it->enabled = enabled;
  return true;
}

bool PoseGraph4Dof::removeLoopEdge(LoopEdgeId id) {
  auto it = std::find_if(loop_edges_.begin(), loop_edges_.end(), [id](const LoopEdge& e) { return e.id == id; });
  if (it == loop_edges_.end()) return false;
  loop_edges_.erase(it);
  return true;
}

bool PoseGraph4Dof::addYawMeasurement(PoseGraphNodeId node, const Eigen::Vector3d& B_m_geomagnetic) {
  checkNode(node, "addYawMeasurement");
  const PoseGraphNode& n = nodes_[node];
  const Eigen::Vector3d B_b = R_b_m_ * B_m_geomagnetic;
  YawMeasurement m;
  m.node = node;
  double horizontal = 0.0;
  if (!levelledFieldDirection(B_b, n.pitch, n.roll, options_.mag_min_horizontal_field_tesla, &m.u_l, &horizontal)) {
    logger_->warnThrottled(kComponent, "yaw_rejected", n.t, 10.0,
                           VIMS_STR("geomagnetic yaw measurement rejected at t="
                                    << n.t << ": " << (B_b.allFinite() ? "horizontal field " : "non-finite field ")
                                    << horizontal << " T below " << options_.mag_min_horizontal_field_tesla << " T"));
    return false;
  }
  m.heading_rad = headingFromLevelledField(m.u_l, north_enu_);
  if (yaw_measurements_.empty()) {
    // First absolute heading: rotate the graph about node 0 so this node has the measured yaw.
    // The VIO's yaw is arbitrary, so the graph may start up to 180 deg off, where the chordal
    // residual's gradient vanishes; this puts the solver in the right basin.
    const double d_yaw = wrapAngle(m.heading_rad - n.yaw_w_b);
    const Eigen::Vector3d p0 = nodes_[0].p_w_b;
    correctNodes(0, d_yaw, p0 - rotationZ(d_yaw) * p0);
    logger_->info(kComponent, VIMS_STR("first geomagnetic heading " << m.heading_rad / kDeg << " deg: graph rotated by "
                                                                    << d_yaw / kDeg << " deg"));
  }
  yaw_measurements_.push_back(m);
  return true;
}

void PoseGraph4Dof::correctNodes(size_t first, double d_yaw, const Eigen::Vector3d& t_corr) {
  const Eigen::Matrix3d R = rotationZ(d_yaw);
  for (size_t i = first; i < nodes_.size(); ++i) {
    nodes_[i].p_w_b = R * nodes_[i].p_w_b + t_corr;
    nodes_[i].yaw_w_b = wrapAngle(nodes_[i].yaw_w_b + d_yaw);
  }
}

std::vector<Eigen::Isometry3d> PoseGraph4Dof::worldPoses() const {
  std::vector<Eigen::Isometry3d> out;
  out.reserve(nodes_.size());
  for (const PoseGraphNode& n : nodes_) out.push_back(n.T_w_b());
  return out;
}

Eigen::Isometry3d PoseGraph4Dof::T_map_odom(PoseGraphNodeId id) const {
  checkNode(id, "T_map_odom");
  const PoseGraphNode& n = nodes_[id];
  // T_w_b T_odom_b^-1 = [Rz(yaw_w) R_rp R_rp^T Rz(yaw_odom)^T | ...] = [Rz(yaw_w - yaw_odom) | t]:
  // computed from the yaws directly so the result is exactly 4-DoF.
  const double yaw_odom = yawPitchRollFromRotation(n.T_odom_b.linear()).yaw;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rotationZ(wrapAngle(n.yaw_w_b - yaw_odom));
  T.translation() = n.p_w_b - T.linear() * n.T_odom_b.translation();
  return T;
}

Eigen::Isometry3d PoseGraph4Dof::T_map_odom() const {
  if (nodes_.empty()) return Eigen::Isometry3d::Identity();
  return T_map_odom(static_cast<PoseGraphNodeId>(nodes_.size() - 1));
}

// ---------------------------------------------------------------------------------------------
// Optimisation
// ---------------------------------------------------------------------------------------------

PoseGraphSnapshot PoseGraph4Dof::snapshot() const {
  PoseGraphSnapshot s;
  s.options = options_;
  s.north_enu = north_enu_;
  s.nodes = nodes_;
  s.sequential_edges = sequential_edges_;
  for (const LoopEdge& e : loop_edges_) {
    if (e.enabled) s.loop_edges.push_back(e);
  }
  s.yaw_measurements = yaw_measurements_;
  s.depth_measurements = depth_measurements_;
  s.surface_z = surface_z_;
  return s;
}

namespace {

/// Every factor of the snapshot must refer to one of its nodes.
void checkSnapshotIndices(const PoseGraphSnapshot& s) {
  const size_t n = s.nodes.size();
  for (const SequentialEdge& e : s.sequential_edges)
    if (e.from >= n || e.to >= n)
      throw std::invalid_argument("PoseGraph4Dof::solve: edge refers to a node outside the snapshot");
  for (const LoopEdge& e : s.loop_edges)
    if (e.match >= n || e.query >= n)
      throw std::invalid_argument("PoseGraph4Dof::solve: edge refers to a node outside the snapshot");
  for (const YawMeasurement& m : s.yaw_measurements)
    if (m.node >= n)
      throw std::invalid_argument("PoseGraph4Dof::solve: yaw factor refers to a node outside the snapshot");
  for (const DepthMeasurement& m : s.depth_measurements)
    if (m.node >= n)
      throw std::invalid_argument("PoseGraph4Dof::solve: depth factor refers to a node outside the snapshot");
}

/// One Ceres solve of a snapshot over the solution arrays (warm-started from their current
/// values) with a given loop loss. Nodes before first_free are held, and factors between held
/// nodes only are left out (they cannot change anything). The problem borrows the manifold and
/// the losses (shared by many residual blocks) and owns the cost functions.
class SolveStage {
 public:
  SolveStage(const PoseGraphSnapshot& s, size_t first_free, ceres::LossFunction* mag_loss, PoseGraphSolution* sol)
      : s_(s), first_free_(first_free), mag_loss_(mag_loss), sol_(*sol), problem_(problemOptions()) {}

  PoseGraphStageReport run(ceres::LossFunction* loop_loss, RobustLoss loop_loss_type, ceres::Solver::Summary* summary) {
    const auto build_start = std::chrono::steady_clock::now();
    addFactors(loop_loss);
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    options.max_num_iterations = s_.options.max_iterations;
    options.function_tolerance = s_.options.function_tolerance;
    if (s_.options.max_solver_time_s > 0.0) options.max_solver_time_in_seconds = s_.options.max_solver_time_s;
    options.num_threads = s_.options.num_threads;
    options.logging_type = ceres::SILENT;
    options.minimizer_progress_to_stdout = false;
    const auto solve_start = std::chrono::steady_clock::now();
    ceres::Solve(options, &problem_, summary);
    PoseGraphStageReport stage;
    stage.loop_loss = toString(loop_loss_type);
    stage.iterations = static_cast<int>(summary->iterations.size()) - 1;
    stage.build_time_s = std::chrono::duration<double>(solve_start - build_start).count();
    stage.solver_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_start).count();
    stage.preprocessor_time_s = summary->preprocessor_time_in_seconds;
    stage.linear_solver_time_s = summary->linear_solver_time_in_seconds;
    stage.jacobian_time_s = summary->residual_evaluation_time_in_seconds + summary->jacobian_evaluation_time_in_seconds;
    stage.termination = summary->message;
    return stage;
  }

 private:
  static ceres::Problem::Options problemOptions() {
    ceres::Problem::Options options;
    options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    return options;
  }

  bool isFree(PoseGraphNodeId i) const { return i >= first_free_; }

  void addNodeBlocks(PoseGraphNodeId i) {
    if (problem_.HasParameterBlock(sol_.p_w_b[i].data())) return;
    problem_.AddParameterBlock(sol_.p_w_b[i].data(), 3);
    problem_.AddParameterBlock(&sol_.yaw_w_b[i], 1, &angle_manifold_);
    if (!isFree(i)) {
      problem_.SetParameterBlockConstant(sol_.p_w_b[i].data());
      problem_.SetParameterBlockConstant(&sol_.yaw_w_b[i]);
    }
  }

  void addRelative(PoseGraphNodeId i, PoseGraphNodeId j, const RelativePose4Dof& z, const Eigen::Vector4d& sqrt_info,
                   ceres::LossFunction* loss) {
    if (!isFree(i) && !isFree(j)) return;
    addNodeBlocks(i);
    addNodeBlocks(j);
    problem_.AddResidualBlock(new RelativePose4DofFactor(z, sqrt_info), loss, sol_.p_w_b[i].data(), &sol_.yaw_w_b[i],
                              sol_.p_w_b[j].data(), &sol_.yaw_w_b[j]);
  }

  void addFactors(ceres::LossFunction* loop_loss) {
    for (const SequentialEdge& e : s_.sequential_edges)
      addRelative(e.from, e.to, e.measurement, e.sqrt_information, nullptr);
    for (const LoopEdge& e : s_.loop_edges) addRelative(e.match, e.query, e.measurement, e.sqrt_information, loop_loss);
    for (const YawMeasurement& m : s_.yaw_measurements) {
      if (!isFree(m.node)) continue;
      addNodeBlocks(m.node);
      problem_.AddResidualBlock(new GeomagneticYawFactor(m.u_l, s_.north_enu, s_.options.mag_yaw_sigma_rad), mag_loss_,
                                &sol_.yaw_w_b[m.node]);
    }
    // Depth factors tie the free nodes' heights to the water surface, whose height is a state
    // (initialised from the first depth when the snapshot has none).
    if (!s_.depth_measurements.empty()) {
      if (!sol_.surface_z) {
        const DepthMeasurement& m = s_.depth_measurements.front();
        sol_.surface_z = s_.nodes[m.node].p_w_b.z() + m.port_offset_z + m.depth_m;
      }
      for (const DepthMeasurement& m : s_.depth_measurements) {
        if (!isFree(m.node)) continue;
        addNodeBlocks(m.node);
        problem_.AddResidualBlock(new PoseGraphDepthFactor(m.depth_m, m.port_offset_z, s_.options.depth_sigma_m),
                                  nullptr, sol_.p_w_b[m.node].data(), &*sol_.surface_z);
      }
    }
    // Gauge: relative edges fix nothing absolute. In a full solve node 0's position is held; its
    // yaw too unless geomagnetic factors make yaw observable (then holding it would fight the
    // magnetometer). In a partial solve the held nodes fix the gauge.
    if (first_free_ == 0) {
      if (problem_.HasParameterBlock(sol_.p_w_b[0].data())) problem_.SetParameterBlockConstant(sol_.p_w_b[0].data());
      if (s_.yaw_measurements.empty() && problem_.HasParameterBlock(&sol_.yaw_w_b[0]))
        problem_.SetParameterBlockConstant(&sol_.yaw_w_b[0]);
    }
  }

  const PoseGraphSnapshot& s_;
  const size_t first_free_;
  ceres::LossFunction* mag_loss_;
  PoseGraphSolution& sol_;
  AngleManifold angle_manifold_;
  ceres::Problem problem_;
};

}  // namespace

PoseGraphSolution PoseGraph4Dof::solve(const PoseGraphSnapshot& s) {
  PoseGraphSolution sol;
  const size_t n = s.nodes.size();
  sol.p_w_b.resize(n);
  sol.yaw_w_b.resize(n);
  for (size_t i = 0; i < n; ++i) {
    sol.p_w_b[i] = s.nodes[i].p_w_b;
    sol.yaw_w_b[i] = s.nodes[i].yaw_w_b;
  }
  sol.surface_z = s.surface_z;
  PoseGraphReport& report = sol.report;
  report.num_nodes = n;
  report.num_sequential_edges = s.sequential_edges.size();
  report.num_loop_edges = s.loop_edges.size();
  report.num_yaw_factors = s.yaw_measurements.size();
  checkSnapshotIndices(s);
  // Partial solve: nodes before first_free_node are held.
  const size_t first_free = std::min(s.first_free_node, n);
  report.num_free_nodes = n - first_free;
  if (report.num_free_nodes == 0 ||
      (s.sequential_edges.empty() && s.loop_edges.empty() && s.yaw_measurements.empty())) {
    report.message = "nothing to optimise";
    return sol;
  }
  const std::unique_ptr<ceres::LossFunction> mag_loss = makeLoss(s.options.mag_loss, s.options.mag_loss_scale);
  auto runSolver = [&](ceres::LossFunction* loop_loss, RobustLoss loop_loss_type, ceres::Solver::Summary* summary) {
    SolveStage stage(s, first_free, mag_loss.get(), &sol);
    report.stages.push_back(stage.run(loop_loss, loop_loss_type, summary));
  };

  report.yaw_gauge_fixed = s.yaw_measurements.empty() && first_free == 0;
  const auto start = std::chrono::steady_clock::now();
  ceres::Solver::Summary summary;
  bool warm_started = false;
  if (s.options.loop_loss == RobustLoss::kCauchy && needsConvexStage(s, first_free)) {
    // Cauchy is not convex: started from the VIO poses, a correct loop whose residual is still
    // many sigmas (accumulated drift) gets almost no weight and the solver can stop short of
    // closing it. So first converge with Huber of the same scale (convex: a unique optimum,
    // bounded pull of wrong loops), then refine with Cauchy, which from there discounts the
    // loops that remain inconsistent.
    const std::unique_ptr<ceres::LossFunction> huber = makeLoss(RobustLoss::kHuber, s.options.loop_loss_scale);
    ceres::Solver::Summary warm;
    runSolver(huber.get(), RobustLoss::kHuber, &warm);
    if (warm.IsSolutionUsable()) {
      const std::unique_ptr<ceres::LossFunction> cauchy = makeLoss(RobustLoss::kCauchy, s.options.loop_loss_scale);
      runSolver(cauchy.get(), RobustLoss::kCauchy, &summary);
      warm_started = true;
      report.iterations = static_cast<int>(warm.iterations.size()) - 1;
      report.initial_cost = warm.initial_cost;
    } else {
      summary = warm;
    }
  } else {
    const std::unique_ptr<ceres::LossFunction> loop_loss = makeLoss(s.options.loop_loss, s.options.loop_loss_scale);
    runSolver(loop_loss.get(), s.options.loop_loss, &summary);
  }
  report.solve_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  report.solved = summary.IsSolutionUsable();
  // Iterations of all stages (entry 0 of each summary is the initial state); the initial cost is
  // that of the first stage, the final cost that of the last (with its own loss).
  if (!warm_started) report.initial_cost = summary.initial_cost;
  report.iterations += static_cast<int>(summary.iterations.size()) - 1;
  report.final_cost = summary.final_cost;
  report.message = summary.message;
  if (!report.solved) {
    // Keep the input poses: a failed solve must not write garbage into the map.
    for (size_t i = 0; i < n; ++i) {
      sol.p_w_b[i] = s.nodes[i].p_w_b;
      sol.yaw_w_b[i] = s.nodes[i].yaw_w_b;
    }
    return sol;
  }
  for (const LoopEdge& e : s.loop_edges) {
    const Eigen::Vector4d r = relativePose4DofResidual(sol.p_w_b[e.match], sol.yaw_w_b[e.match], sol.p_w_b[e.query],
                                                       sol.yaw_w_b[e.query], e.measurement);
    report.loop_residuals.push_back(LoopEdgeResidual{e.id, e.sqrt_information.cwiseProduct(r).norm()});
  }
  return sol;
}

void PoseGraph4Dof::applySolution(const PoseGraphSolution& solution) {
  const size_t m = solution.p_w_b.size();
  if (m > nodes_.size() || solution.yaw_w_b.size() != m)
    throw std::invalid_argument("PoseGraph4Dof::applySolution: solution does not match the graph");
  if (!solution.report.solved || m == 0) return;
  // Drift correction of the snapshot's last node, carried over to the nodes added since.
  const PoseGraphNode& last = nodes_[m - 1];
  const double d_yaw = wrapAngle(solution.yaw_w_b[m - 1] - last.yaw_w_b);
  const Eigen::Vector3d t_corr = solution.p_w_b[m - 1] - rotationZ(d_yaw) * last.p_w_b;
  for (size_t i = 0; i < m; ++i) {
    nodes_[i].p_w_b = solution.p_w_b[i];
    nodes_[i].yaw_w_b = wrapAngle(solution.yaw_w_b[i]);
  }
  if (solution.surface_z && std::isfinite(*solution.surface_z)) surface_z_ = solution.surface_z;
  correctNodes(m, d_yaw, t_corr);
}

DepthMeasurement depthMeasurementAt(PoseGraphNodeId node, const PoseGraphNode& n, double depth_m,
                                    const Eigen::Vector3d& p_b_port) {
  DepthMeasurement m;
  m.node = node;
  m.depth_m = depth_m;
  const Eigen::Matrix3d R_rp =
      (Eigen::AngleAxisd(n.pitch, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(n.roll, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  m.port_offset_z = (R_rp * p_b_port).z();
  return m;
}

bool PoseGraph4Dof::addDepthMeasurement(PoseGraphNodeId node, double depth_m, const Eigen::Vector3d& p_b_port) {
  checkNode(node, "addDepthMeasurement");
  const PoseGraphNode& n = nodes_[node];
  if (!std::isfinite(depth_m) || !p_b_port.allFinite()) {
    if (logger_)
      logger_->warnThrottled(kComponent, "depth_nan", n.t, 10.0, "non-finite pressure depth: no depth factor");
    return false;
  }
  const DepthMeasurement m = depthMeasurementAt(node, n, depth_m, p_b_port);
  if (!surface_z_) surface_z_ = n.p_w_b.z() + m.port_offset_z + depth_m;
  depth_measurements_.push_back(m);
  return true;
}

PoseGraphReport PoseGraph4Dof::optimise() {
  PoseGraphSolution solution = solve(snapshot());
  applySolution(solution);
  const PoseGraphReport& r = solution.report;
  logger_->debug(kComponent, VIMS_STR("optimised " << r.num_nodes << " nodes, " << r.num_loop_edges << " loops, "
                                                   << r.num_yaw_factors << " yaw factors: cost " << r.initial_cost
                                                   << " -> " << r.final_cost << " in " << r.iterations
                                                   << " iterations, " << r.solve_time_s * 1e3 << " ms"));
  return r;
}

}  // namespace vims
