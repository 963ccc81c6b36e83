#pragma once
/// @file pose_graph.h
/// @brief The global 4-DoF pose graph of VIMS (paper: "Global Pose Graph Optimization"):
/// keyframe nodes with world position and yaw optimised (roll and pitch held at the VIO's),
/// sequential VIO edges, loop edges with a robust loss, and geomagnetic yaw factors.
/// Residuals, parameterisation, gauge and options: docs/pose_graph.md.
///
/// Threading model. PoseGraph4Dof itself is not thread-safe; its owner serialises calls (one
/// mutex). The expensive part is split off so it can run on a worker thread without the lock:
///   PoseGraphSnapshot s = graph.snapshot();          // under the lock, O(graph size) copy
///   PoseGraphSolution x = PoseGraph4Dof::solve(s);   // no lock; new nodes may arrive meanwhile
///   graph.applySolution(x);                          // under the lock
/// applySolution() writes the optimised poses of the snapshot's nodes and moves the nodes added
/// since by the drift correction of the snapshot's last node (as VINS-Mono does), so the newest
/// keyframes stay consistent with the corrected map. optimise() runs the three steps in place.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "vims_common/config_reader.h"
#include "vims_common/log.h"
#include "vims_common/sequence_config.h"
#include "vims_pose_graph/pose_graph_factors.h"

namespace vims {

template <typename Options>
class OptionTable;

using PoseGraphNodeId = uint32_t;
using LoopEdgeId = uint32_t;

enum class RobustLoss { kNone, kHuber, kCauchy };
std::string toString(RobustLoss loss);
/// "none" / "huber" / "cauchy"; throws std::invalid_argument otherwise.
RobustLoss robustLossFromString(const std::string& name);

struct PoseGraphOptions {
  /// Sequential (VIO) edges. Sigma of each component of the relative position and of the
  /// relative yaw between consecutive keyframes, growing with the distance d travelled between
  /// them: sigma(d) = sqrt(sigma_0^2 + (sigma_per_m * d)^2), because VIO drift accumulates
  /// with distance, while sigma_0 keeps short edges from becoming infinitely stiff.
  /// These must cover the VIO's real drift: if the accumulated odometry uncertainty between two
  /// keyframes is far below their actual drift, a correct loop looks like an outlier to the
  /// robust loss and is discounted (docs/pose_graph.md, "Choosing the sigmas").
  double odometry_position_sigma_m = 0.05;
  double odometry_position_sigma_per_m = 0.05;               ///< [m/m]
  double odometry_yaw_sigma_rad = 0.1 * M_PI / 180.0;        ///< key odometry_yaw_sigma_deg
  double odometry_yaw_sigma_per_m_rad = 0.5 * M_PI / 180.0;  ///< [rad/m], key odometry_yaw_sigma_per_m_deg
  /// The size of the VIO's drift learnt from the loops (odometry_drift.h; docs/pose_graph.md,
  /// "Odometry drift learnt from the loops"): once the loops of this many revisit events give
  /// chains of odometry edges, the sigmas above are scaled (variance multipliers for position
  /// and yaw, within [scale_min, scale_max]) to the values under which the loops' discrepancies
  /// against the chains are most likely. The sigmas above then give only the shape.
  bool learn_odometry_drift = false;
  int odometry_drift_min_chains = 3;
  double odometry_drift_scale_min = 1e-3;
  double odometry_drift_scale_max = 10.0;

  /// Loop edges: sigmas of a PnP-verified relative pose, and the robust loss applied to the
  /// whitened residual (scale in sigmas). Cauchy's cost grows only logarithmically, so a wrong
  /// loop that passed verification costs less to ignore than to bend the odometry chain for.
  /// Cauchy is solved in two stages (Huber, then Cauchy; see solve()). A scale of 3 sigmas keeps
  /// correct loops after long drift: at 1 sigma, ignoring a correct loop becomes cheaper than
  /// spreading a systematic VIO drift over the chain, and it is dropped.
  double loop_position_sigma_m = 0.10;
  double loop_yaw_sigma_rad = 1.0 * M_PI / 180.0;  ///< key loop_yaw_sigma_deg
  /// Weight each loop edge by its own measurement covariance (LoopAttempt::sigma, from its
  /// inliers' geometry and residuals; docs/pose_graph.md, "Loop edge measurement and
  /// information") instead of the constant sigmas above, which remain for loops without one.
  /// Per component sigma = sqrt(sigma_inliers^2 + floor^2): the floors stand for what the
  /// inliers cannot show, the errors all points of a keyframe share (the VIO's attitude at the
  /// match, a landmark scale error).
  bool loop_sigma_from_inliers = false;
  double loop_position_sigma_floor_m = 0.005;
  double loop_yaw_sigma_floor_rad = 0.05 * M_PI / 180.0;  ///< key loop_yaw_sigma_floor_deg
  RobustLoss loop_loss = RobustLoss::kCauchy;
  double loop_loss_scale = 3.0;

  /// Geomagnetic yaw factors: sigma of the heading from the low-passed field (tilt-compensated
  /// with the VIO roll/pitch), a robust loss against local magnetic disturbances (hull, coil,
  /// ferrous objects), and the minimum horizontal field for a usable heading.
  double mag_yaw_sigma_rad = 3.0 * M_PI / 180.0;  ///< key mag_yaw_sigma_deg
  RobustLoss mag_loss = RobustLoss::kHuber;
  double mag_loss_scale = 2.0;
  double mag_min_horizontal_field_tesla = 5.0e-6;
  /// [m] Depth factor of a keyframe with a pressure depth (sequences with a pressure sensor): the
  /// sensor's ~1 cm plus the keyframe's interpolation and the VIO's attitude at the port lever.
  double depth_sigma_m = 0.02;

  /// Solver.
  int max_iterations = 50;
  double max_solver_time_s = 2.0;  ///< wall-clock cap of one solve; 0 = no cap
  int num_threads = 1;
  /// Ceres stops when an iteration lowers the cost by less than this fraction: the end-of-data
  /// solve and direct PoseGraph4Dof use (Ceres' default), ...
  double function_tolerance = 1e-6;
  /// ... and the PoseGraphManager's solves after loops and every N keyframes: their last
  /// iterations only turn the whole graph by hundredths of a degree (docs/pose_graph.md).
  double online_function_tolerance = 1e-3;

  /// What the PoseGraphManager optimises (docs/pose_graph.md, "Cost of the optimisation"); the
  /// end-of-data solve always covers the whole graph.
  /// After new loops: true = only the keyframes from the earliest node of the new loops on (the
  /// older ones are held, as VINS-Mono); false = the whole graph.
  bool loop_solve_from_earliest_node = true;
  /// Periodic solves (no new loop; the yaw factors of the newest keyframes): only the newest
  /// this many keyframes of the run, the older ones held; 0 = the whole graph.
  int window_keyframes = 100;
  /// Local loop solves (docs/pose_graph.md, "Local loop solves"): when every new loop starts
  /// within this many sigmas of its measurement (whitened residual at the current poses: the map
  /// already agrees with it, as for the later loops of a burst at one revisit), the solve after
  /// it frees only the newest `window_keyframes` keyframes and the loops' query nodes (the match
  /// side is held) -- the loop correction -- and the solve from the loops' earliest node is
  /// deferred: it runs once for all loops deferred since, when the oldest of them is
  /// PoseGraphManagerOptions::optimise_every_n_keyframes keyframes old, or with the next loop
  /// that is not local, or at the end of data. 0 (or window_keyframes 0) = off.
  double loop_local_solve_max_sigmas = 3.0;

  /// The table of the fields (keys, bounds): drives fromReader, validation and toYaml.
  static const OptionTable<PoseGraphOptions>& optionTable();

  /// Keys as the field names, with `_deg` instead of `_rad` for angles. Unknown keys and
  /// out-of-range values throw ConfigError naming the key.
  static PoseGraphOptions fromReader(const ConfigReader& reader);
  /// Throws std::invalid_argument naming the first invalid field (for options built in code).
  void validate() const;
  std::string toYaml() const;
};

/// One keyframe.
struct PoseGraphNode {
  double t = 0.0;                                              ///< keyframe time [s]
  Eigen::Isometry3d T_odom_b = Eigen::Isometry3d::Identity();  ///< VIO pose (local frame)
  double pitch = 0.0;                                          ///< from the VIO, fixed [rad]
  double roll = 0.0;                                           ///< from the VIO, fixed [rad]
  Eigen::Vector3d p_w_b = Eigen::Vector3d::Zero();             ///< world position (optimised)
  double yaw_w_b = 0.0;                                        ///< world yaw (optimised)

  Eigen::Isometry3d T_w_b() const;
};

struct SequentialEdge {
  PoseGraphNodeId from = 0;
  PoseGraphNodeId to = 0;
  RelativePose4Dof measurement;
  Eigen::Vector4d sqrt_information = Eigen::Vector4d::Ones();
};

struct LoopEdge {
  LoopEdgeId id = 0;
  PoseGraphNodeId match = 0;  ///< the revisited (older) keyframe
  PoseGraphNodeId query = 0;  ///< the current keyframe
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();
  RelativePose4Dof measurement;
  Eigen::Vector4d sqrt_information = Eigen::Vector4d::Ones();
  bool enabled = true;
};

/// The depth of the pressure port below the surface at a node: z_w + port_offset_z + depth = z_s.
struct DepthMeasurement {
  PoseGraphNodeId node = 0;
  double depth_m = 0.0;
  double port_offset_z = 0.0;  ///< (Ry(pitch) Rx(roll) p_b_port)_z: the port's height above the body
};

/// The depth measurement of `node` (pose `n`): the port's height above the body from the node's
/// fixed roll and pitch (yaw does not change a height).
DepthMeasurement depthMeasurementAt(PoseGraphNodeId node, const PoseGraphNode& n, double depth_m,
                                    const Eigen::Vector3d& p_b_port);

struct YawMeasurement {
  PoseGraphNodeId node = 0;
  Eigen::Vector2d u_l = Eigen::Vector2d::UnitX();  ///< levelled horizontal field direction
  double heading_rad = 0.0;                        ///< the yaw it measures (for reports)
};

/// Everything solve() needs, copied out of the graph.
struct PoseGraphSnapshot {
  PoseGraphOptions options;
  Eigen::Vector2d north_enu = Eigen::Vector2d::UnitY();
  std::vector<PoseGraphNode> nodes;
  std::vector<SequentialEdge> sequential_edges;
  std::vector<LoopEdge> loop_edges;  ///< enabled ones only
  std::vector<YawMeasurement> yaw_measurements;
  std::vector<DepthMeasurement> depth_measurements;
  /// Height of the water surface in the world frame, the solve's starting value of that state;
  /// unset: the first depth measurement's.
  std::optional<double> surface_z;

  /// Partial solve: nodes [0, first_free_node) are held at their poses (they fix the gauge) and
  /// factors between held nodes are left out; 0 = full solve. Exact when the held part is
  /// already at its optimum given the rest, an approximation otherwise (docs/pose_graph.md,
  /// "Cost of the optimisation").
  size_t first_free_node = 0;
  /// Loops with an id below this were in a previous solve. With a Cauchy loop loss, the convex
  /// Huber stage runs only when a newer loop starts outside the loss scale; 0 = every loop is new.
  LoopEdgeId first_new_loop_id = 0;
};

struct LoopEdgeResidual {
  LoopEdgeId id = 0;
  double whitened_norm = 0.0;  ///< |diag(sqrt_info) r| after the solve (in sigmas)
};

/// One Ceres run of a solve (Cauchy loops: a Huber stage, then a Cauchy stage).
struct PoseGraphStageReport {
  std::string loop_loss;  ///< the loop loss of this stage
  int iterations = 0;
  double build_time_s = 0.0;          ///< building the Ceres problem
  double solver_time_s = 0.0;         ///< ceres::Solve, all of it
  double preprocessor_time_s = 0.0;   ///< of which in Ceres' preprocessing (ordering, symbolic factorisation)
  double linear_solver_time_s = 0.0;  ///< of which in the linear solver
  double jacobian_time_s = 0.0;       ///< of which evaluating residuals and Jacobians
  std::string termination;            ///< Ceres' message
};

struct PoseGraphReport {
  bool solved = false;  ///< false when there was nothing to optimise or Ceres failed
  int iterations = 0;   ///< over all stages
  double initial_cost = 0.0;
  double final_cost = 0.0;
  double solve_time_s = 0.0;
  size_t num_nodes = 0;
  size_t num_free_nodes = 0;  ///< nodes optimised (the others held at their snapshot poses)
  size_t num_sequential_edges = 0;
  size_t num_loop_edges = 0;  ///< enabled loop edges used
  size_t num_yaw_factors = 0;
  bool yaw_gauge_fixed = false;  ///< node 0's yaw held constant (no yaw factors)
  std::string message;           ///< Ceres' termination message
  std::vector<PoseGraphStageReport> stages;
  std::vector<LoopEdgeResidual> loop_residuals;
};

struct PoseGraphSolution {
  std::vector<Eigen::Vector3d> p_w_b;  ///< per snapshot node
  std::vector<double> yaw_w_b;
  std::optional<double> surface_z;
  PoseGraphReport report;
};

class PoseGraph4Dof {
 public:
  /// `magnetometer` gives the site declination and R_b_m (sequence YAML). Throws
  /// std::invalid_argument for invalid options.
  PoseGraph4Dof(const PoseGraphOptions& options, const MagnetometerCalibration& magnetometer,
                LoggerPtr logger = nullptr);

  /// Adds a keyframe with its VIO pose. Its initial world pose is the VIO pose moved by the
  /// current drift correction T_map_odom (identity for the first node). Times must not decrease
  /// and the pose must be finite (std::invalid_argument otherwise).
  PoseGraphNodeId addNode(double t, const Eigen::Isometry3d& T_odom_b);

  /// The VIO relative pose from node `from` to node `to` (both VIO poses must share one VIO
  /// frame). Throws std::invalid_argument for unknown ids or from == to.
  void addSequentialEdge(PoseGraphNodeId from, PoseGraphNodeId to);

  /// A verified loop: T_match_query is the pose of the query body in the match body frame.
  /// Returns the edge id. Throws std::invalid_argument for unknown ids, equal ids or a
  /// non-finite pose.
  LoopEdgeId addLoopEdge(PoseGraphNodeId match, PoseGraphNodeId query, const Eigen::Isometry3d& T_match_query);
  /// Excludes / re-includes a loop edge; false when the id is unknown (or removed).
  bool setLoopEdgeEnabled(LoopEdgeId id, bool enabled);
  /// Deletes a loop edge for good; false when the id is unknown.
  bool removeLoopEdge(LoopEdgeId id);

  /// A geomagnetic yaw factor at `node` from the low-passed geomagnetic field measured in the
  /// magnetometer frame (tesla; the alternating coil field removed). It is rotated into the body
  /// frame with R_b_m and tilt-compensated with the node's VIO roll/pitch. Returns false (and
  /// logs a throttled warning) when the field is not finite or its horizontal part is below
  /// mag_min_horizontal_field_tesla. The first accepted measurement rotates the whole graph
  /// about node 0 to its heading, so the solver starts near the right yaw basin.
  bool addYawMeasurement(PoseGraphNodeId node, const Eigen::Vector3d& B_m_geomagnetic);

  /// A pressure depth (port below the surface, metres) at `node`, with the port's position in the
  /// body frame. The first one sets the surface height. False (with a throttled warning) for a
  /// non-finite depth.
  bool addDepthMeasurement(PoseGraphNodeId node, double depth_m, const Eigen::Vector3d& p_b_port);
  size_t numDepthMeasurements() const { return depth_measurements_.size(); }

  /// snapshot() + solve() + applySolution().
  PoseGraphReport optimise();
  PoseGraphSnapshot snapshot() const;
  /// Solves a snapshot. Touches no shared state (safe on a worker thread).
  static PoseGraphSolution solve(const PoseGraphSnapshot& snapshot);
  /// Writes a solution back (see the threading model above). Throws std::invalid_argument if
  /// the solution has more nodes than the graph.
  void applySolution(const PoseGraphSolution& solution);

  size_t numNodes() const { return nodes_.size(); }
  const PoseGraphNode& node(PoseGraphNodeId id) const { return nodes_.at(id); }
  const std::vector<LoopEdge>& loopEdges() const { return loop_edges_; }
  const std::vector<SequentialEdge>& sequentialEdges() const { return sequential_edges_; }
  size_t numYawMeasurements() const { return yaw_measurements_.size(); }
  const PoseGraphOptions& options() const { return options_; }

  /// World pose of a node (Rz(yaw_w_b) Ry(pitch) Rx(roll), p_w_b).
  Eigen::Isometry3d worldPose(PoseGraphNodeId id) const { return nodes_.at(id).T_w_b(); }
  std::vector<Eigen::Isometry3d> worldPoses() const;
  /// Drift correction at a node: T_map_odom = T_w_b * T_odom_b^-1, a yaw rotation plus a
  /// translation (roll and pitch cancel). The no-argument form uses the latest node (identity
  /// when the graph is empty): the map->odom transform to publish.
  Eigen::Isometry3d T_map_odom(PoseGraphNodeId id) const;
  Eigen::Isometry3d T_map_odom() const;

 private:
  void checkNode(PoseGraphNodeId id, const char* what) const;
  /// Applies the 4-DoF correction p <- Rz(d_yaw) p + t_corr, yaw <- yaw + d_yaw to the world
  /// poses of nodes [first, end).
  void correctNodes(size_t first, double d_yaw, const Eigen::Vector3d& t_corr);

  PoseGraphOptions options_;
  Eigen::Vector2d north_enu_;
  Eigen::Matrix3d R_b_m_;
  LoggerPtr logger_;
  std::vector<PoseGraphNode> nodes_;
  std::vector<SequentialEdge> sequential_edges_;
  std::vector<LoopEdge> loop_edges_;
  std::vector<YawMeasurement> yaw_measurements_;
  std::vector<DepthMeasurement> depth_measurements_;
  std::optional<double> surface_z_;
  LoopEdgeId next_loop_id_ = 0;
};

}  // namespace vims
