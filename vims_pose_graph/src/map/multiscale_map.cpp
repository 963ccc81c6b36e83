#include "vims_pose_graph/multiscale_map.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "vims_common/fnv1a.h"
#include "vims_pose_graph/angles.h"

namespace vims {

namespace {
constexpr const char* kComponent = "pose_graph_map";
constexpr int kDirectIndexDepth = 2;  ///< unused by verification; BowDatabase needs one

bool isFinitePose(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  return T.translation().allFinite() && R.allFinite() &&
         (R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 && R.determinant() > 0.0;
}

}  // namespace

MultiScaleMap::MultiScaleMap(std::shared_ptr<const BinaryVocabulary> vocabulary, const PoseGraphOptions& graph_options,
                             double declination_rad, LoggerPtr logger)
    : vocabulary_(std::move(vocabulary)),
      graph_options_(graph_options),
      north_enu_(magneticNorthEnu(declination_rad)),
      logger_(logger ? std::move(logger) : Logger::nullLogger()),
      drift_(graph_options) {
  graph_options_.validate();
  if (!std::isfinite(declination_rad)) throw std::invalid_argument("MultiScaleMap: declination is not finite");
  if (vocabulary_ && !vocabulary_->empty()) {
    const std::vector<uint8_t> bytes = vocabulary_->serialize();
    vocabulary_checksum_ = fnv1a64(bytes.data(), bytes.size());
    bow_ = std::make_unique<BowDatabase>(vocabulary_, kDirectIndexDepth);
  }
}

// ---------------------------------------------------------------------------------------------
// Building
// ---------------------------------------------------------------------------------------------

void MultiScaleMap::checkNode(PoseGraphNodeId id, const char* what) const {
  if (id >= nodes_.size())
    throw std::invalid_argument(std::string("MultiScaleMap::") + what + ": unknown node " + std::to_string(id));
}

size_t visualSubmapMemoryBytes(const MultiScaleMap& map, PoseGraphNodeId id) {
  const std::shared_ptr<const VisualSubmap> submap = map.visualSubmap(id);
  return submap->keypoints.capacity() * sizeof(cv::KeyPoint) +
         submap->descriptors.capacity() * sizeof(BinaryDescriptor) +
         submap->normalized.capacity() * sizeof(Eigen::Vector2d) +
         map.node(id).bow.entries.capacity() * sizeof(BowEntry);
}

void MultiScaleMap::setRunCameraExtrinsic(const Eigen::Isometry3d& T_b_c) {
  run_T_b_c_ = T_b_c;
  for (MapSession& session : sessions_)
    if (!session.loaded) session.T_b_c = T_b_c;
}

uint32_t MultiScaleMap::addSession(uint32_t vio_session, bool loaded) {
  MapSession s;
  s.vio_session = vio_session;
  s.loaded = loaded;
  s.T_b_c = run_T_b_c_;  // a loaded session's is then set from its file
  sessions_.push_back(s);
  session_parent_.push_back(static_cast<uint32_t>(sessions_.size() - 1));
  session_yaw_count_.push_back(0);
  return static_cast<uint32_t>(sessions_.size() - 1);
}

PoseGraphNodeId MultiScaleMap::addNode(double t, uint32_t session, const Eigen::Isometry3d& T_odom_b,
                                       const Eigen::Vector3d& p_w_b, double yaw_w_b, VisualSubmap visual,
                                       bool magnetic_coverage) {
  if (visual.descriptors.size() != visual.keypoints.size() || visual.normalized.size() != visual.keypoints.size())
    throw std::invalid_argument(
        "MultiScaleMap::addNode: keypoints, descriptors and normalised points differ in number");
  const uint32_t num_keypoints = static_cast<uint32_t>(visual.keypoints.size());
  BowVector bow = std::move(visual.bow);
  visual.bow = BowVector();
  std::shared_ptr<const VisualSubmap> resident;
  if (!visual.empty()) {
    // The describer appends keypoints in several passes (ORB, tracked, dense corners), which
    // leaves up to as much spare capacity again in each vector; the map keeps a submap for the
    // whole run, so it keeps exactly its contents.
    visual.keypoints.shrink_to_fit();
    visual.descriptors.shrink_to_fit();
    visual.normalized.shrink_to_fit();
    resident = std::make_shared<const VisualSubmap>(std::move(visual));
  }
  return appendNode(t, session, T_odom_b, p_w_b, yaw_w_b, std::move(bow), num_keypoints, std::move(resident),
                    magnetic_coverage);
}

PoseGraphNodeId MultiScaleMap::appendNode(double t, uint32_t session, const Eigen::Isometry3d& T_odom_b,
                                          const Eigen::Vector3d& p_w_b, double yaw_w_b, BowVector bow,
                                          uint32_t num_keypoints, std::shared_ptr<const VisualSubmap> resident,
                                          bool magnetic_coverage) {
  if (session >= sessions_.size()) throw std::invalid_argument("MultiScaleMap::addNode: unknown session");
  if (!std::isfinite(t) || !isFinitePose(T_odom_b) || !p_w_b.allFinite() || !std::isfinite(yaw_w_b))
    throw std::invalid_argument("MultiScaleMap::addNode: non-finite time or pose");
  MapNode n;
  const YawPitchRoll ypr = yawPitchRollFromRotation(T_odom_b.linear());
  n.pose.t = t;
  n.pose.T_odom_b = T_odom_b;
  n.pose.pitch = ypr.pitch;
  n.pose.roll = ypr.roll;
  n.pose.p_w_b = p_w_b;
  n.pose.yaw_w_b = wrapAngle(yaw_w_b);
  n.session = session;
  n.magnetic_coverage = magnetic_coverage;
  n.num_keypoints = num_keypoints;
  const PoseGraphNodeId id = static_cast<PoseGraphNodeId>(nodes_.size());
  if (num_keypoints > 0 && !bow.empty() && bow_) {
    n.bow_image = bow_->add(bow);
    image_to_node_.push_back(id);
  }
  bow.entries.shrink_to_fit();
  n.bow = std::move(bow);
  nodes_.push_back(std::move(n));
  resident_submaps_.push_back(std::move(resident));
  MapSession& s = sessions_[session];
  if (s.num_nodes == 0) s.first_node = id;
  s.last_node = id;
  ++s.num_nodes;
  return id;
}

void MultiScaleMap::addSequentialEdge(PoseGraphNodeId from, PoseGraphNodeId to) {
  checkNode(from, "addSequentialEdge");
  checkNode(to, "addSequentialEdge");
  if (from == to || nodes_[from].session != nodes_[to].session)
    throw std::invalid_argument("MultiScaleMap::addSequentialEdge: needs two nodes of one session");
  SequentialEdge e;
  e.from = from;
  e.to = to;
  e.measurement = relativePose4DofFromPoses(nodes_[from].pose.T_odom_b, nodes_[to].pose.T_odom_b);
  // The noise model of PoseGraph4Dof::addSequentialEdge, with the drift learnt so far.
  e.sqrt_information = sequentialEdgeSqrtInformation(graph_options_, e.measurement, drift_.fit().scale);
  sequential_edges_.push_back(e);
}

std::vector<size_t> MultiScaleMap::runOdometryEdges() const {
  std::vector<size_t> out;
  for (size_t k = 0; k < sequential_edges_.size(); ++k) {
    const SequentialEdge& e = sequential_edges_[k];
    const uint32_t session = nodes_[e.from].session;
    if (session == nodes_[e.to].session && !sessions_[session].loaded) out.push_back(k);
  }
  return out;
}

const OdometryDriftFit& MultiScaleMap::learnOdometryDrift() {
  const std::vector<size_t> run_edges = runOdometryEdges();
  std::vector<SequentialEdge> edges;
  edges.reserve(run_edges.size());
  for (size_t k : run_edges) edges.push_back(sequential_edges_[k]);
  const OdometryDriftScale before = drift_.fit().scale;
  const OdometryDriftFit& fit = drift_.update(edges, loop_edges_);
  if (fit.scale.position == before.position && fit.scale.yaw == before.yaw) return fit;  // most loops
  // Re-weigh the run's edges: a loaded session's edges keep the weights of the run that recorded them.
  for (size_t k : run_edges)
    sequential_edges_[k].sqrt_information =
        sequentialEdgeSqrtInformation(graph_options_, sequential_edges_[k].measurement, fit.scale);
  return fit;
}

void MultiScaleMap::addSessionLink(PoseGraphNodeId from, PoseGraphNodeId to, double sigma_position_m,
                                   double sigma_yaw_rad) {
  checkNode(from, "addSessionLink");
  checkNode(to, "addSessionLink");
  if (from == to || !(sigma_position_m > 0.0) || !(sigma_yaw_rad > 0.0))
    throw std::invalid_argument("MultiScaleMap::addSessionLink: invalid nodes or sigmas");
  SequentialEdge e;
  e.from = from;
  e.to = to;
  e.measurement = RelativePose4Dof();  // "the vehicle stayed where it was"
  e.sqrt_information << 1.0 / sigma_position_m, 1.0 / sigma_position_m, 1.0 / sigma_position_m, 1.0 / sigma_yaw_rad;
  sequential_edges_.push_back(e);
  uniteSessions(nodes_[from].session, nodes_[to].session);
}

LoopEdgeId MultiScaleMap::addLoopEdge(PoseGraphNodeId match, PoseGraphNodeId query,
                                      const Eigen::Isometry3d& T_match_query,
                                      const Eigen::Vector4d& measurement_sigma) {
  checkNode(match, "addLoopEdge");
  checkNode(query, "addLoopEdge");
  if (match == query || !isFinitePose(T_match_query))
    throw std::invalid_argument("MultiScaleMap::addLoopEdge: equal nodes or invalid relative pose");
  LoopEdge e;
  e.id = next_loop_id_++;
  e.match = match;
  e.query = query;
  e.T_match_query = T_match_query;
  e.measurement = relativePose4DofFromRelative(T_match_query, nodes_[match].pose.pitch, nodes_[match].pose.roll);
  const PoseGraphOptions& o = graph_options_;
  if (o.loop_sigma_from_inliers && measurement_sigma.allFinite() && (measurement_sigma.array() >= 0.0).all()) {
    const Eigen::Vector4d floor(o.loop_position_sigma_floor_m, o.loop_position_sigma_floor_m,
                                o.loop_position_sigma_floor_m, o.loop_yaw_sigma_floor_rad);
    e.sqrt_information = (measurement_sigma.array().square() + floor.array().square()).sqrt().inverse();
  } else {
    const double ip = 1.0 / o.loop_position_sigma_m;
    e.sqrt_information << ip, ip, ip, 1.0 / o.loop_yaw_sigma_rad;
  }
  loop_edges_.push_back(e);
  uniteSessions(nodes_[match].session, nodes_[query].session);
  return e.id;
}

bool MultiScaleMap::addYawMeasurement(PoseGraphNodeId node, const Eigen::Vector3d& B_b) {
  checkNode(node, "addYawMeasurement");
  const MapNode& n = nodes_[node];
  YawMeasurement m;
  m.node = node;
  double horizontal = 0.0;
  if (!levelledFieldDirection(B_b, n.pose.pitch, n.pose.roll, graph_options_.mag_min_horizontal_field_tesla, &m.u_l,
                              &horizontal)) {
    logger_->warnThrottled(
        kComponent, "yaw_rejected", n.pose.t, 10.0,
        VIMS_STR("geomagnetic yaw rejected at t="
                 << n.pose.t << ": " << (B_b.allFinite() ? "horizontal field " : "non-finite field ") << horizontal
                 << " T below " << graph_options_.mag_min_horizontal_field_tesla << " T"));
    return false;
  }
  m.heading_rad = headingFromLevelledField(m.u_l, north_enu_);
  const uint32_t component = componentOf(node);
  bool component_has_yaw = false;
  for (uint32_t s = 0; s < sessions_.size(); ++s)
    if (findSession(s) == component && session_yaw_count_[s] > 0) component_has_yaw = true;
  if (!component_has_yaw && !componentHasLoadedSessions(component)) {
    // First absolute heading of this component: rotate it about its oldest keyframe so this
    // node has the measured yaw (see PoseGraph4Dof::addYawMeasurement for why).
    const double d_yaw = wrapAngle(m.heading_rad - n.pose.yaw_w_b);
    const Eigen::Vector3d p0 = nodes_[sessions_[component].first_node].pose.p_w_b;
    Correction4Dof c;
    c.d_yaw = d_yaw;
    c.t = p0 - rotationZ(d_yaw) * p0;
    moveComponent(component, c);
    logger_->info(kComponent,
                  VIMS_STR("first geomagnetic heading " << m.heading_rad * 180.0 / M_PI << " deg: component rotated by "
                                                        << d_yaw * 180.0 / M_PI << " deg"));
  }
  ++session_yaw_count_[n.session];
  yaw_measurements_.push_back(m);
  return true;
}

bool MultiScaleMap::setYawMeasurementField(size_t index, const Eigen::Vector3d& B_b) {
  if (index >= yaw_measurements_.size())
    throw std::invalid_argument("MultiScaleMap::setYawMeasurementField: no yaw measurement " + std::to_string(index));
  YawMeasurement& m = yaw_measurements_[index];
  const PoseGraphNode& n = nodes_[m.node].pose;
  Eigen::Vector2d u_l;
  double horizontal = 0.0;
  if (!levelledFieldDirection(B_b, n.pitch, n.roll, graph_options_.mag_min_horizontal_field_tesla, &u_l, &horizontal))
    return false;
  m.u_l = u_l;
  m.heading_rad = headingFromLevelledField(u_l, north_enu_);
  return true;
}

bool MultiScaleMap::addDepthMeasurement(PoseGraphNodeId node, double depth_m, const Eigen::Vector3d& p_b_port) {
  checkNode(node, "addDepthMeasurement");
  const PoseGraphNode& n = nodes_[node].pose;
  if (!std::isfinite(depth_m) || !p_b_port.allFinite()) {
    logger_->warnThrottled(kComponent, "depth_nan", n.t, 10.0, "non-finite pressure depth: no depth factor");
    return false;
  }
  depth_measurements_.push_back(depthMeasurementAt(node, n, depth_m, p_b_port));
  return true;
}

uint32_t MultiScaleMap::addMagneticSubmap(const MagneticSubmapDraft& draft) {
  checkNode(draft.tied_node, "addMagneticSubmap");
  MagneticSubmap m;
  m.id = static_cast<uint32_t>(magnetic_submaps_.size());
  m.tied_node = draft.tied_node;
  m.t = draft.t;
  m.coil = draft.coil;
  m.signature_enu = draft.signature_enu;
  m.radius_m = draft.radius_m;
  m.num_members = draft.num_members;
  magnetic_submaps_.push_back(m);
  return m.id;
}

void MultiScaleMap::setMagneticCoverage(PoseGraphNodeId node, bool covered) {
  checkNode(node, "setMagneticCoverage");
  nodes_[node].magnetic_coverage = covered;
}

// ---------------------------------------------------------------------------------------------
// Components
// ---------------------------------------------------------------------------------------------

uint32_t MultiScaleMap::findSession(uint32_t session) const {
  while (session_parent_.at(session) != session) session = session_parent_[session];
  return session;
}

void MultiScaleMap::uniteSessions(uint32_t a, uint32_t b) {
  const uint32_t ra = findSession(a);
  const uint32_t rb = findSession(b);
  if (ra == rb) return;
  // The older session stays the root, so a component's representative is its oldest session
  // (and the reference component is always rooted at session 0).
  if (ra < rb)
    session_parent_[rb] = ra;
  else
    session_parent_[ra] = rb;
}

uint32_t MultiScaleMap::componentOf(PoseGraphNodeId node) const {
  checkNode(node, "componentOf");
  return findSession(nodes_[node].session);
}

bool MultiScaleMap::inReferenceComponent(PoseGraphNodeId node) const {
  return !nodes_.empty() && componentOf(node) == componentOf(0);
}

bool MultiScaleMap::componentHasLoadedSessions(uint32_t component) const {
  for (uint32_t s = 0; s < sessions_.size(); ++s)
    if (sessions_[s].loaded && findSession(s) == component) return true;
  return false;
}

void MultiScaleMap::applyCorrection(MapNode& n, const Correction4Dof& c) const {
  n.pose.p_w_b = rotationZ(c.d_yaw) * n.pose.p_w_b + c.t;
  n.pose.yaw_w_b = wrapAngle(n.pose.yaw_w_b + c.d_yaw);
}

void MultiScaleMap::moveComponent(uint32_t component, const Correction4Dof& correction) {
  for (MapNode& n : nodes_)
    if (findSession(n.session) == component) applyCorrection(n, correction);
}

Correction4Dof correctionBetween(const Eigen::Vector3d& p_old, double yaw_old, const Eigen::Vector3d& p_new,
                                 double yaw_new) {
  Correction4Dof c;
  c.d_yaw = wrapAngle(yaw_new - yaw_old);
  c.t = p_new - rotationZ(c.d_yaw) * p_old;
  return c;
}

// ---------------------------------------------------------------------------------------------
// Optimisation
// ---------------------------------------------------------------------------------------------

ComponentSnapshot MultiScaleMap::snapshotComponent(PoseGraphNodeId node) const {
  ComponentSnapshot cs;
  const uint32_t component = componentOf(node);
  std::vector<int64_t> index(nodes_.size(), -1);
  for (PoseGraphNodeId i = 0; i < nodes_.size(); ++i) {
    if (findSession(nodes_[i].session) != component) continue;
    index[i] = static_cast<int64_t>(cs.ids.size());
    cs.ids.push_back(i);
    cs.snapshot.nodes.push_back(nodes_[i].pose);
  }
  cs.snapshot.options = graph_options_;
  cs.snapshot.north_enu = north_enu_;
  for (const SequentialEdge& e : sequential_edges_) {
    if (index[e.from] < 0 || index[e.to] < 0) continue;
    SequentialEdge local = e;
    local.from = static_cast<PoseGraphNodeId>(index[e.from]);
    local.to = static_cast<PoseGraphNodeId>(index[e.to]);
    cs.snapshot.sequential_edges.push_back(local);
  }
  for (const LoopEdge& e : loop_edges_) {
    if (!e.enabled || index[e.match] < 0 || index[e.query] < 0) continue;
    LoopEdge local = e;
    local.match = static_cast<PoseGraphNodeId>(index[e.match]);
    local.query = static_cast<PoseGraphNodeId>(index[e.query]);
    cs.snapshot.loop_edges.push_back(local);
  }
  for (const YawMeasurement& m : yaw_measurements_) {
    if (index[m.node] < 0) continue;
    YawMeasurement local = m;
    local.node = static_cast<PoseGraphNodeId>(index[m.node]);
    cs.snapshot.yaw_measurements.push_back(local);
  }
  for (const DepthMeasurement& m : depth_measurements_) {
    if (index[m.node] < 0) continue;
    DepthMeasurement local = m;
    local.node = static_cast<PoseGraphNodeId>(index[m.node]);
    cs.snapshot.depth_measurements.push_back(local);
  }
  return cs;
}

bool MultiScaleMap::applySolution(const ComponentSnapshot& cs, const PoseGraphSolution& solution) {
  const size_t m = cs.ids.size();
  if (solution.p_w_b.size() != m || solution.yaw_w_b.size() != m) return false;
  for (PoseGraphNodeId id : cs.ids)
    if (id >= nodes_.size()) return false;
  if (!solution.report.solved || m == 0) return true;

  // Corrections of the last snapshot node of each session, measured against the poses the
  // nodes have now (newer keyframes were placed relative to those).
  std::map<uint32_t, Correction4Dof> session_correction;
  for (size_t k = 0; k < m; ++k) {
    const MapNode& n = nodes_[cs.ids[k]];
    session_correction[n.session] =
        correctionBetween(n.pose.p_w_b, n.pose.yaw_w_b, solution.p_w_b[k], solution.yaw_w_b[k]);
  }
  const MapNode& last = nodes_[cs.ids.back()];
  const Correction4Dof fallback =
      correctionBetween(last.pose.p_w_b, last.pose.yaw_w_b, solution.p_w_b.back(), solution.yaw_w_b.back());
  std::vector<bool> in_snapshot(nodes_.size(), false);
  for (size_t k = 0; k < m; ++k) {
    MapNode& n = nodes_[cs.ids[k]];
    n.pose.p_w_b = solution.p_w_b[k];
    n.pose.yaw_w_b = wrapAngle(solution.yaw_w_b[k]);
    in_snapshot[cs.ids[k]] = true;
  }
  const uint32_t component = componentOf(cs.ids.front());
  for (PoseGraphNodeId i = 0; i < nodes_.size(); ++i) {
    if (in_snapshot[i] || findSession(nodes_[i].session) != component) continue;
    const auto it = session_correction.find(nodes_[i].session);
    applyCorrection(nodes_[i], it != session_correction.end() ? it->second : fallback);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Queries
// ---------------------------------------------------------------------------------------------

Eigen::Isometry3d MultiScaleMap::T_map_odom(PoseGraphNodeId id) const {
  checkNode(id, "T_map_odom");
  const PoseGraphNode& n = nodes_[id].pose;
  const double yaw_odom = yawPitchRollFromRotation(n.T_odom_b.linear()).yaw;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = rotationZ(wrapAngle(n.yaw_w_b - yaw_odom));
  T.translation() = n.p_w_b - T.linear() * n.T_odom_b.translation();
  return T;
}

Eigen::Vector3d MultiScaleMap::magneticSubmapPosition(const MagneticSubmap& submap) const {
  return nodes_.at(submap.tied_node).pose.p_w_b;
}

std::vector<PoseGraphNodeId> MultiScaleMap::clusteredNodes(const MagneticSubmap& submap, double cluster_margin_m,
                                                           ClusterMembers members) const {
  std::vector<PoseGraphNodeId> out;
  const Eigen::Vector2d centre = magneticSubmapPosition(submap).head<2>();
  const uint32_t component = componentOf(submap.tied_node);
  const double reach = submap.radius_m + cluster_margin_m;
  for (PoseGraphNodeId i = 0; i < nodes_.size(); ++i) {
    const MapNode& n = nodes_[i];
    const bool member = members == ClusterMembers::kVisualSubmaps ? n.bow_image >= 0 : !n.bow.empty();
    if (!member || findSession(n.session) != component) continue;
    if ((n.pose.p_w_b.head<2>() - centre).norm() <= reach) out.push_back(i);
  }
  return out;
}

}  // namespace vims
