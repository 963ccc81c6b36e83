#include "vims_pose_graph/multiscale_map.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>

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

constexpr uint64_t kFnvOffsetBasis = 1469598103934665603ull;

/// FNV-1a 64 of `size` bytes, continuing from `h` (kFnvOffsetBasis for a fresh hash).
uint64_t fnv1a64(const uint8_t* data, size_t size, uint64_t h = kFnvOffsetBasis) {
  for (size_t i = 0; i < size; ++i) {
    h ^= data[i];
    h *= 1099511628211ull;
  }
  return h;
}
}  // namespace

MultiScaleMap::MultiScaleMap(std::shared_ptr<const BinaryVocabulary> vocabulary, const PoseGraphOptions& graph_options,
                             double declination_rad, LoggerPtr logger)
    : vocabulary_(std::move(vocabulary)),
      graph_options_(graph_options),
      north_enu_(magneticNorthEnu(declination_rad)),
      logger_(logger ? std::move(logger) : Logger::nullLogger()) {
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

size_t visualSubmapMemoryBytes(const VisualSubmap& submap) {
  return submap.keypoints.capacity() * sizeof(cv::KeyPoint) + submap.descriptors.capacity() * sizeof(BinaryDescriptor) +
         submap.normalized.capacity() * sizeof(Eigen::Vector2d) + submap.bow.entries.capacity() * sizeof(BowEntry);
}

uint32_t MultiScaleMap::addSession(uint32_t vio_session, bool loaded) {
  MapSession s;
  s.vio_session = vio_session;
  s.loaded = loaded;
  sessions_.push_back(s);
  session_parent_.push_back(static_cast<uint32_t>(sessions_.size() - 1));
  session_yaw_count_.push_back(0);
  return static_cast<uint32_t>(sessions_.size() - 1);
}

PoseGraphNodeId MultiScaleMap::addNode(double t, uint32_t session, const Eigen::Isometry3d& T_odom_b,
                                       const Eigen::Vector3d& p_w_b, double yaw_w_b, VisualSubmap visual,
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
  const PoseGraphNodeId id = static_cast<PoseGraphNodeId>(nodes_.size());
  if (!visual.empty() && !visual.bow.empty() && bow_) {
    n.bow_image = bow_->add(visual.bow);
    image_to_node_.push_back(id);
  }
  // The describer appends keypoints in several passes (ORB, tracked, dense corners), which
  // leaves up to as much spare capacity again in each vector; the map keeps a submap for the
  // whole run, so it keeps exactly its contents.
  visual.keypoints.shrink_to_fit();
  visual.descriptors.shrink_to_fit();
  visual.normalized.shrink_to_fit();
  visual.bow.entries.shrink_to_fit();
  n.visual = std::move(visual);
  nodes_.push_back(std::move(n));
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
  // Same noise model as PoseGraph4Dof::addSequentialEdge: VIO drift grows with the distance.
  const double d = e.measurement.p_li_j.norm();
  const double sigma_p = std::hypot(graph_options_.odometry_position_sigma_m, graph_options_.odometry_position_sigma_per_m * d);
  const double sigma_yaw = std::hypot(graph_options_.odometry_yaw_sigma_rad, graph_options_.odometry_yaw_sigma_per_m_rad * d);
  e.sqrt_information << 1.0 / sigma_p, 1.0 / sigma_p, 1.0 / sigma_p, 1.0 / sigma_yaw;
  sequential_edges_.push_back(e);
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
                                      const Eigen::Isometry3d& T_match_query) {
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
  const double ip = 1.0 / graph_options_.loop_position_sigma_m;
  e.sqrt_information << ip, ip, ip, 1.0 / graph_options_.loop_yaw_sigma_rad;
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
    logger_->warnThrottled(kComponent, "yaw_rejected", n.pose.t, 10.0,
                           VIMS_STR("geomagnetic yaw rejected at t=" << n.pose.t << ": "
                                    << (B_b.allFinite() ? "horizontal field " : "non-finite field ") << horizontal
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
    logger_->info(kComponent, VIMS_STR("first geomagnetic heading " << m.heading_rad * 180.0 / M_PI
                                       << " deg: component rotated by " << d_yaw * 180.0 / M_PI << " deg"));
  }
  ++session_yaw_count_[n.session];
  yaw_measurements_.push_back(m);
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
    session_correction[n.session] = correctionBetween(n.pose.p_w_b, n.pose.yaw_w_b, solution.p_w_b[k], solution.yaw_w_b[k]);
  }
  const MapNode& last = nodes_[cs.ids.back()];
  const Correction4Dof fallback = correctionBetween(last.pose.p_w_b, last.pose.yaw_w_b, solution.p_w_b.back(),
                                                    solution.yaw_w_b.back());
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
    const bool member = members == ClusterMembers::kVisualSubmaps ? n.bow_image >= 0 : !n.visual.bow.empty();
    if (!member || findSession(n.session) != component) continue;
    if ((n.pose.p_w_b.head<2>() - centre).norm() <= reach) out.push_back(i);
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// File format (docs/pose_graph.md, "Map file"): little-endian, FNV-1a 64 checksum trailer.
// ---------------------------------------------------------------------------------------------

namespace {

constexpr char kMagic[8] = {'V', 'I', 'M', 'S', 'M', 'A', 'P', '\0'};
constexpr size_t kHeaderBytes = 8 + 4 + 8;  // magic, version, payload size
/// Bounds far above any real map, so a corrupt count cannot request huge memory before the
/// reader runs out of bytes.
constexpr uint32_t kMaxCount = 100000000u;

class ByteReader {
 public:
  ByteReader(const std::vector<uint8_t>& bytes, size_t begin, size_t end, const std::string& source)
      : bytes_(bytes), pos_(begin), end_(end), source_(source) {}

  [[noreturn]] void fail(const std::string& what) const {
    throw MapFileError("map file '" + source_ + "': " + what + " (at byte " + std::to_string(pos_) + ")");
  }
  void need(size_t n) const {
    if (n > end_ - pos_) fail("corrupt: a record runs past the end of the payload");
  }
  uint8_t u8() {
    need(1);
    return bytes_[pos_++];
  }
  uint32_t u32() {
    need(4);
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(bytes_[pos_++]) << (8 * i);
    return v;
  }
  uint64_t u64() {
    need(8);
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(bytes_[pos_++]) << (8 * i);
    return v;
  }
  int32_t i32() { return static_cast<int32_t>(u32()); }
  float f32() {
    const uint32_t u = u32();
    float v;
    std::memcpy(&v, &u, 4);
    return v;
  }
  double f64() {
    const uint64_t u = u64();
    double v;
    std::memcpy(&v, &u, 8);
    return v;
  }
  double finite(const char* what) {
    const double v = f64();
    if (!std::isfinite(v)) fail(std::string("corrupt: non-finite ") + what);
    return v;
  }
  Eigen::Vector3d vec(const char* what) {
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = finite(what);
    return v;
  }
  std::string str(size_t max_length) {
    const uint32_t n = u32();
    if (n > max_length) fail("corrupt: string too long");
    need(n);
    std::string s(bytes_.begin() + static_cast<std::ptrdiff_t>(pos_), bytes_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
    pos_ += n;
    return s;
  }
  /// A count of records of at least `min_record_bytes` each: must fit in what is left.
  uint32_t count(size_t min_record_bytes, const char* what) {
    const uint32_t n = u32();
    if (n > kMaxCount || static_cast<uint64_t>(n) * min_record_bytes > end_ - pos_)
      fail(std::string("corrupt: impossible number of ") + what + " (" + std::to_string(n) + ")");
    return n;
  }
  Eigen::Isometry3d pose(const char* what) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = vec(what);
    Eigen::Matrix3d R;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) R(r, c) = finite(what);
    if ((R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || R.determinant() <= 0.0)
      fail(std::string("corrupt: not a rotation in ") + what);
    T.linear() = R;
    return T;
  }
  const uint8_t* take(size_t n) {
    need(n);
    const uint8_t* p = bytes_.data() + pos_;
    pos_ += n;
    return p;
  }
  bool atEnd() const { return pos_ == end_; }

 private:
  const std::vector<uint8_t>& bytes_;
  size_t pos_;
  size_t end_;
  const std::string& source_;
};

}  // namespace

/// Little-endian writer of the map format with three targets: counting only (the payload size
/// must precede the payload, and the checksum covers it), memory (serialize()), or a file
/// streamed through a 1 MiB buffer (save(): a 750 s map is ~330 MB, which must not be held
/// twice). The checksum is FNV-1a 64 of everything written, kept incrementally.
class MapFileWriter {
 public:
  /// Counts bytes only.
  MapFileWriter() = default;
  /// Into memory; take the bytes with release().
  explicit MapFileWriter(std::vector<uint8_t>* memory) : memory_(memory) {}
  /// Streams to `out` (opened in binary mode).
  explicit MapFileWriter(std::ostream* out) : out_(out) {}

  void u8(uint8_t v) { raw(&v, 1); }
  void u32(uint32_t v) {
    uint8_t b[4];
    for (int i = 0; i < 4; ++i) b[i] = static_cast<uint8_t>(v >> (8 * i));
    raw(b, 4);
  }
  void u64(uint64_t v) {
    uint8_t b[8];
    for (int i = 0; i < 8; ++i) b[i] = static_cast<uint8_t>(v >> (8 * i));
    raw(b, 8);
  }
  void i32(int32_t v) { u32(static_cast<uint32_t>(v)); }
  void f32(float v) {
    uint32_t u;
    std::memcpy(&u, &v, 4);
    u32(u);
  }
  void f64(double v) {
    uint64_t u;
    std::memcpy(&u, &v, 8);
    u64(u);
  }
  void vec(const Eigen::Vector3d& v) {
    for (int i = 0; i < 3; ++i) f64(v[i]);
  }
  void str(const std::string& s) {
    u32(static_cast<uint32_t>(s.size()));
    raw(reinterpret_cast<const uint8_t*>(s.data()), s.size());
  }
  void raw(const uint8_t* p, size_t n) {
    size_ += n;
    if (!memory_ && !out_) return;
    buffer_.insert(buffer_.end(), p, p + n);
    if (buffer_.size() >= kFlushBytes) flush();
  }
  /// Translation and the row-major rotation matrix: lossless, so a loaded map re-serialises to
  /// the same bytes (a quaternion round trip changes the last bits).
  void pose(const Eigen::Isometry3d& T) {
    vec(T.translation());
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) f64(T.linear()(r, c));
  }
  /// Appends the checksum of everything written so far and flushes.
  void finishWithChecksum() {
    flush();
    u64(hash_);
    flush();
  }
  /// Bytes written (or counted) so far.
  uint64_t size() const { return size_; }

 private:
  static constexpr size_t kFlushBytes = size_t{1} << 20;

  void flush() {
    hash_ = fnv1a64(buffer_.data(), buffer_.size(), hash_);
    if (memory_) memory_->insert(memory_->end(), buffer_.begin(), buffer_.end());
    if (out_) out_->write(reinterpret_cast<const char*>(buffer_.data()), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }

  std::vector<uint8_t>* memory_ = nullptr;
  std::ostream* out_ = nullptr;
  std::vector<uint8_t> buffer_;
  uint64_t size_ = 0;
  uint64_t hash_ = kFnvOffsetBasis;
};

void MultiScaleMap::writePayload(MapFileWriter& w, const std::string& vocabulary_path) const {
  w.str(vocabulary_ ? vocabulary_->descriptorType() : std::string());
  w.str(vocabulary_path);
  w.u64(vocabulary_checksum_);
  w.u64(vocabulary_ ? vocabulary_->numWords() : 0);

  w.u32(static_cast<uint32_t>(sessions_.size()));
  for (uint32_t s = 0; s < sessions_.size(); ++s) {
    w.u32(sessions_[s].vio_session);
    w.u32(session_parent_[s]);
  }
  w.u32(static_cast<uint32_t>(nodes_.size()));
  for (const MapNode& n : nodes_) {
    w.f64(n.pose.t);
    w.u32(n.session);
    w.pose(n.pose.T_odom_b);
    w.vec(n.pose.p_w_b);
    w.f64(n.pose.yaw_w_b);
    w.u8(n.magnetic_coverage ? 1 : 0);
    const VisualSubmap& v = n.visual;
    w.u32(static_cast<uint32_t>(v.keypoints.size()));
    for (size_t i = 0; i < v.keypoints.size(); ++i) {
      const cv::KeyPoint& kp = v.keypoints[i];
      w.f32(kp.pt.x);
      w.f32(kp.pt.y);
      w.f32(kp.size);
      w.f32(kp.angle);
      w.f32(kp.response);
      w.i32(kp.octave);
      w.f64(v.normalized[i].x());
      w.f64(v.normalized[i].y());
      uint8_t d[kDescriptorBytes];
      v.descriptors[i].toBytes(d);
      w.raw(d, kDescriptorBytes);
    }
    w.u32(static_cast<uint32_t>(v.bow.entries.size()));
    for (const BowEntry& e : v.bow.entries) {
      w.u32(e.word);
      w.f64(e.weight);
    }
  }
  w.u32(static_cast<uint32_t>(sequential_edges_.size()));
  for (const SequentialEdge& e : sequential_edges_) {
    w.u32(e.from);
    w.u32(e.to);
    w.vec(e.measurement.p_li_j);
    w.f64(e.measurement.yaw_i_j);
    for (int i = 0; i < 4; ++i) w.f64(e.sqrt_information[i]);
  }
  w.u32(static_cast<uint32_t>(loop_edges_.size()));
  for (const LoopEdge& e : loop_edges_) {
    w.u32(e.id);
    w.u32(e.match);
    w.u32(e.query);
    w.pose(e.T_match_query);
    w.vec(e.measurement.p_li_j);
    w.f64(e.measurement.yaw_i_j);
    for (int i = 0; i < 4; ++i) w.f64(e.sqrt_information[i]);
    w.u8(e.enabled ? 1 : 0);
  }
  w.u32(static_cast<uint32_t>(yaw_measurements_.size()));
  for (const YawMeasurement& m : yaw_measurements_) {
    w.u32(m.node);
    w.f64(m.u_l.x());
    w.f64(m.u_l.y());
    w.f64(m.heading_rad);
  }
  w.u32(static_cast<uint32_t>(magnetic_submaps_.size()));
  for (const MagneticSubmap& m : magnetic_submaps_) {
    w.u32(m.tied_node);
    w.f64(m.t);
    w.vec(m.signature_enu);
    w.f64(m.radius_m);
    w.u32(m.num_members);
  }
}

void MultiScaleMap::writeFile(MapFileWriter& w, const std::string& vocabulary_path) const {
  MapFileWriter counter;
  writePayload(counter, vocabulary_path);
  w.raw(reinterpret_cast<const uint8_t*>(kMagic), 8);
  w.u32(kFileVersion);
  w.u64(counter.size());
  writePayload(w, vocabulary_path);
  w.finishWithChecksum();
}

std::vector<uint8_t> MultiScaleMap::serialize(const std::string& vocabulary_path) const {
  std::vector<uint8_t> bytes;
  MapFileWriter w(&bytes);
  writeFile(w, vocabulary_path);
  return bytes;
}

void MultiScaleMap::save(const std::string& path, const std::string& vocabulary_path) const {
  // Write to a temporary file and rename, so a crash mid-write never leaves a half map under
  // the real name.
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write map file '" + tmp + "'");
    MapFileWriter w(&out);
    writeFile(w, vocabulary_path);
    out.flush();
    if (!out) throw std::runtime_error("I/O error writing map file '" + tmp + "'");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error("cannot rename '" + tmp + "' to map file '" + path + "'");
}

void MultiScaleMap::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw MapFileError("map file '" + path + "': cannot be opened");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw MapFileError("map file '" + path + "': read error");
  deserialize(bytes, path);
}

void MultiScaleMap::deserialize(const std::vector<uint8_t>& bytes, const std::string& source) {
  if (!nodes_.empty() || !sessions_.empty())
    throw std::logic_error("MultiScaleMap::deserialize: the map must be empty (load before feeding keyframes)");
  auto fail = [&](const std::string& what) -> MapFileError { return MapFileError("map file '" + source + "': " + what); };
  if (bytes.size() < kHeaderBytes + 8) throw fail("truncated (" + std::to_string(bytes.size()) + " bytes)");
  if (std::memcmp(bytes.data(), kMagic, 8) != 0) throw fail("not a VIMS map (bad magic)");
  uint32_t version = 0;
  for (int i = 0; i < 4; ++i) version |= static_cast<uint32_t>(bytes[8 + static_cast<size_t>(i)]) << (8 * i);
  if (version != kFileVersion)
    throw fail("unsupported version " + std::to_string(version) + " (this build reads " + std::to_string(kFileVersion) + ")");
  uint64_t payload = 0;
  for (int i = 0; i < 8; ++i) payload |= static_cast<uint64_t>(bytes[12 + static_cast<size_t>(i)]) << (8 * i);
  const uint64_t expected = kHeaderBytes + payload + 8;
  if (payload > bytes.size() || expected > bytes.size())
    throw fail("truncated (" + std::to_string(bytes.size()) + " of " + std::to_string(expected) + " bytes)");
  if (expected < bytes.size())
    throw fail("oversized (" + std::to_string(bytes.size()) + " bytes, header says " + std::to_string(expected) + ")");
  uint64_t stored_checksum = 0;
  for (int i = 0; i < 8; ++i) stored_checksum |= static_cast<uint64_t>(bytes[expected - 8 + static_cast<size_t>(i)]) << (8 * i);
  if (fnv1a64(bytes.data(), expected - 8) != stored_checksum) throw fail("checksum mismatch (file corrupt)");

  ByteReader r(bytes, kHeaderBytes, static_cast<size_t>(expected - 8), source);
  const std::string descriptor_type = r.str(64);
  const std::string vocabulary_path = r.str(4096);
  const uint64_t vocabulary_checksum = r.u64();
  const uint64_t vocabulary_words = r.u64();
  const std::string own_type = vocabulary_ ? vocabulary_->descriptorType() : std::string();
  if (descriptor_type != own_type)
    throw fail("built with '" + descriptor_type + "' descriptors, but this run uses '" + own_type +
               "' (the map's loop closing mode must use the same descriptor)");
  if (vocabulary_checksum != vocabulary_checksum_)
    throw fail("built with another vocabulary ('" + vocabulary_path + "', checksum " + std::to_string(vocabulary_checksum) +
               "); this run's vocabulary has checksum " + std::to_string(vocabulary_checksum_));
  (void)vocabulary_words;

  // Parse into a fresh map first: nothing of this map changes unless the whole file is valid.
  MultiScaleMap m(vocabulary_, graph_options_, 0.0, logger_);
  m.north_enu_ = north_enu_;
  const uint32_t num_sessions = r.count(8, "sessions");
  std::vector<uint32_t> parents(num_sessions);
  for (uint32_t s = 0; s < num_sessions; ++s) {
    const uint32_t vio = r.u32();
    parents[s] = r.u32();
    if (parents[s] >= num_sessions || parents[s] > s) r.fail("corrupt: session parent out of range");
    m.addSession(vio, true);
  }
  const uint32_t num_nodes = r.count(8 + 4 + 96 + 24 + 8 + 1 + 8, "keyframes");
  const size_t num_words = vocabulary_ ? vocabulary_->numWords() : 0;
  for (uint32_t i = 0; i < num_nodes; ++i) {
    const double t = r.finite("keyframe time");
    const uint32_t session = r.u32();
    if (session >= num_sessions) r.fail("corrupt: keyframe session out of range");
    const Eigen::Isometry3d T_odom_b = r.pose("keyframe VIO pose");
    const Eigen::Vector3d p_w_b = r.vec("keyframe world position");
    const double yaw_w_b = r.finite("keyframe world yaw");
    const bool coverage = r.u8() != 0;
    VisualSubmap v;
    const uint32_t num_keypoints = r.count(6 * 4 + 16 + kDescriptorBytes, "keypoints");
    v.keypoints.reserve(num_keypoints);
    for (uint32_t k = 0; k < num_keypoints; ++k) {
      cv::KeyPoint kp;
      kp.pt.x = r.f32();
      kp.pt.y = r.f32();
      kp.size = r.f32();
      kp.angle = r.f32();
      kp.response = r.f32();
      kp.octave = r.i32();
      const double nx = r.finite("keypoint coordinate");
      const double ny = r.finite("keypoint coordinate");
      if (!std::isfinite(kp.pt.x) || !std::isfinite(kp.pt.y) || kp.octave < 0 || kp.octave > 64)
        r.fail("corrupt: invalid keypoint");
      v.keypoints.push_back(kp);
      v.normalized.emplace_back(nx, ny);
      v.descriptors.push_back(BinaryDescriptor::fromBytes(r.take(kDescriptorBytes)));
    }
    const uint32_t num_entries = r.count(12, "BoW entries");
    for (uint32_t k = 0; k < num_entries; ++k) {
      BowEntry e;
      e.word = r.u32();
      e.weight = r.finite("BoW weight");
      if (e.word >= num_words || !(e.weight > 0.0)) r.fail("corrupt: BoW entry outside the vocabulary");
      if (!v.bow.entries.empty() && e.word <= v.bow.entries.back().word) r.fail("corrupt: BoW entries not sorted");
      v.bow.entries.push_back(e);
    }
    m.addNode(t, session, T_odom_b, p_w_b, yaw_w_b, std::move(v), coverage);
  }
  const uint32_t num_sequential = r.count(8 + 32 + 32, "sequential edges");
  for (uint32_t i = 0; i < num_sequential; ++i) {
    SequentialEdge e;
    e.from = r.u32();
    e.to = r.u32();
    if (e.from >= num_nodes || e.to >= num_nodes || e.from == e.to) r.fail("corrupt: sequential edge node out of range");
    e.measurement.p_li_j = r.vec("sequential edge");
    e.measurement.yaw_i_j = r.finite("sequential edge");
    for (int k = 0; k < 4; ++k) e.sqrt_information[k] = r.finite("sequential edge information");
    if ((e.sqrt_information.array() <= 0.0).any()) r.fail("corrupt: non-positive edge information");
    m.sequential_edges_.push_back(e);
  }
  const uint32_t num_loops = r.count(12 + 96 + 32 + 32 + 1, "loop edges");
  for (uint32_t i = 0; i < num_loops; ++i) {
    LoopEdge e;
    e.id = r.u32();
    e.match = r.u32();
    e.query = r.u32();
    if (e.match >= num_nodes || e.query >= num_nodes || e.match == e.query) r.fail("corrupt: loop edge node out of range");
    e.T_match_query = r.pose("loop edge");
    e.measurement.p_li_j = r.vec("loop edge");
    e.measurement.yaw_i_j = r.finite("loop edge");
    for (int k = 0; k < 4; ++k) e.sqrt_information[k] = r.finite("loop edge information");
    if ((e.sqrt_information.array() <= 0.0).any()) r.fail("corrupt: non-positive edge information");
    e.enabled = r.u8() != 0;
    m.loop_edges_.push_back(e);
    m.next_loop_id_ = std::max(m.next_loop_id_, e.id + 1);
  }
  const uint32_t num_yaw = r.count(4 + 24, "yaw factors");
  for (uint32_t i = 0; i < num_yaw; ++i) {
    YawMeasurement y;
    y.node = r.u32();
    if (y.node >= num_nodes) r.fail("corrupt: yaw factor node out of range");
    y.u_l.x() = r.finite("yaw factor");
    y.u_l.y() = r.finite("yaw factor");
    y.heading_rad = r.finite("yaw factor");
    if (std::abs(y.u_l.norm() - 1.0) > 1e-6) r.fail("corrupt: yaw factor direction is not a unit vector");
    m.yaw_measurements_.push_back(y);
    ++m.session_yaw_count_[m.nodes_[y.node].session];
  }
  const uint32_t num_magnetic = r.count(4 + 8 + 24 + 8 + 4, "magnetic submaps");
  for (uint32_t i = 0; i < num_magnetic; ++i) {
    MagneticSubmapDraft d;
    d.tied_node = r.u32();
    if (d.tied_node >= num_nodes) r.fail("corrupt: magnetic submap keyframe out of range");
    d.t = r.finite("magnetic submap");
    d.signature_enu = r.vec("magnetic submap signature");
    d.radius_m = r.finite("magnetic submap radius");
    if (!(d.radius_m >= 0.0)) r.fail("corrupt: negative magnetic submap radius");
    d.num_members = r.u32();
    m.addMagneticSubmap(d);
  }
  if (!r.atEnd()) r.fail("corrupt: trailing bytes in the payload");
  m.session_parent_ = parents;
  // Sessions are linked only through their edges; the union-find of the file must agree.
  for (uint32_t s = 0; s < num_sessions; ++s)
    if (m.sessions_[s].num_nodes == 0) r.fail("corrupt: empty session");

  nodes_ = std::move(m.nodes_);
  sessions_ = std::move(m.sessions_);
  session_parent_ = std::move(m.session_parent_);
  session_yaw_count_ = std::move(m.session_yaw_count_);
  sequential_edges_ = std::move(m.sequential_edges_);
  loop_edges_ = std::move(m.loop_edges_);
  next_loop_id_ = m.next_loop_id_;
  yaw_measurements_ = std::move(m.yaw_measurements_);
  magnetic_submaps_ = std::move(m.magnetic_submaps_);
  bow_ = std::move(m.bow_);
  image_to_node_ = std::move(m.image_to_node_);
  logger_->info(kComponent, VIMS_STR("loaded map '" << source << "': " << nodes_.size() << " keyframes, "
                                     << sessions_.size() << " sessions, " << loop_edges_.size() << " loops, "
                                     << magnetic_submaps_.size() << " magnetic submaps"));
}

}  // namespace vims
