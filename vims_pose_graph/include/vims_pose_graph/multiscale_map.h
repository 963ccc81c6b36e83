#pragma once
/// @file multiscale_map.h
/// @brief The multi-scale visual-magnetic map (paper, "Multi-Scale Map Construction") together
/// with the pose graph it hangs on: keyframe nodes (VIO pose, optimised world pose, visual
/// submap), VIO sessions, sequential / session-link / loop edges, geomagnetic yaw factors,
/// magnetic submaps and the bag-of-words database; 4-DoF snapshots for PoseGraph4Dof::solve;
/// binary save and load. docs/pose_graph.md, "Map", "Sessions" and "Map file".
///
/// Why not PoseGraph4Dof's own bookkeeping: that class holds one VIO chain with non-decreasing
/// times. The map also holds several VIO sessions of one run (a VIO reset), and sessions loaded
/// from a file recorded on another day (their times are another run's clock), possibly not yet
/// connected to the current run (before relocalisation). It keeps sessions in connected
/// components (union-find over sessions, joined by session links and loops) and solves one
/// component at a time with PoseGraph4Dof::solve, whose residuals, losses and gauge it reuses.
///
/// Not thread-safe; the PoseGraphManager serialises access.

#include <Eigen/Geometry>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "vims_common/log.h"
#include "vims_pose_graph/bow_database.h"
#include "vims_pose_graph/keyframe_description.h"
#include "vims_pose_graph/magnetic_submap.h"
#include "vims_pose_graph/odometry_drift.h"
#include "vims_pose_graph/pose_graph.h"

namespace vims {

/// Thrown by MultiScaleMap::load for a missing, truncated, corrupt or incompatible map file;
/// what() names the file and the problem.
class MapFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A chain of keyframes from one VIO session (one odom frame).
struct MapSession {
  uint32_t vio_session = 0;  ///< KeyframeData::session it came from
  bool loaded = false;       ///< from a map file (another run)
  PoseGraphNodeId first_node = 0;
  PoseGraphNodeId last_node = 0;
  uint32_t num_nodes = 0;
  /// The camera extrinsic of the run that made the session (its keyframes' submaps are in that
  /// camera): a repeat run's rig may be another, or recalibrated, and a loop against a loaded
  /// keyframe must use the teach run's (docs/pose_graph.md, "Map file").
  Eigen::Isometry3d T_b_c = Eigen::Isometry3d::Identity();
};

/// One keyframe of the map.
struct MapNode {
  PoseGraphNode pose;    ///< t, T_odom_b, fixed pitch/roll, optimised p_w_b and yaw_w_b
  uint32_t session = 0;  ///< index into MultiScaleMap::sessions()
  /// The BoW vector of its image; also kept when its keypoints were not (a culled submap).
  BowVector bow;
  /// Keypoints of its visual submap (MultiScaleMap::visualSubmap); 0 = none (no usable corners,
  /// or culled).
  uint32_t num_keypoints = 0;
  int64_t bow_image = -1;  ///< BowDatabase id, -1 without a visual submap
  /// The magnetometer was producing signature windows around this keyframe's time. Keyframes
  /// without (magnetometer off) cannot be clustered by magnetism, so the magnetic stage leaves
  /// them in the visual search instead of making them unreachable.
  bool magnetic_coverage = false;

  bool hasVisualSubmap() const { return num_keypoints > 0; }
};

/// The four numbers of a 4-DoF correction p <- Rz(d_yaw) p + t, yaw <- yaw + d_yaw.
struct Correction4Dof {
  double d_yaw = 0.0;
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

/// The correction that moves a pose (p_old, yaw_old) to (p_new, yaw_new).
Correction4Dof correctionBetween(const Eigen::Vector3d& p_old, double yaw_old, const Eigen::Vector3d& p_new,
                                 double yaw_new);

/// The snapshot of one connected component with the global ids of its nodes (snapshot index k
/// is node ids[k]; ids are ascending, so node 0 of the snapshot -- the gauge PoseGraph4Dof::solve
/// fixes -- is the component's oldest keyframe).
struct ComponentSnapshot {
  PoseGraphSnapshot snapshot;
  std::vector<PoseGraphNodeId> ids;
};

/// Writer of the map file format (multiscale_map.cpp).
class MapFileWriter;

/// What MultiScaleMap::save writes: the whole map, or only the sessions loaded from a map file
/// with what lies among their keyframes (a localisation run adds nothing to the map it uses).
enum class MapSaveScope { kAll, kLoadedSessions };

class MultiScaleMap {
 public:
  /// File format version written by save(). Versions 1 (before several coils: its magnetic
  /// submaps are the first coil's), 2 (before the sessions' camera extrinsics: this run's is
  /// assumed) and 3 (the keypoints inline, read at once) are read too; save() also writes 3.
  static constexpr uint32_t kFileVersion = 4;

  /// `vocabulary` may be null only for a map that never gets visual submaps. `declination_rad`
  /// is the site's magnetic declination (east positive). Throws std::invalid_argument for
  /// invalid graph options.
  MultiScaleMap(std::shared_ptr<const BinaryVocabulary> vocabulary, const PoseGraphOptions& graph_options,
                double declination_rad, LoggerPtr logger = nullptr);

  // ---- building
  /// The camera extrinsic of this run's sessions: the sequence's T_b_c, set before the first
  /// session, then the VIO's online estimate as it arrives (every session of this run takes
  /// the latest; loaded sessions keep their file's). Also what a loaded file of version 1 or 2,
  /// which does not record it, is assumed to have.
  void setRunCameraExtrinsic(const Eigen::Isometry3d& T_b_c);
  /// A new session (a new chain); returns its index.
  uint32_t addSession(uint32_t vio_session, bool loaded);
  /// Appends a keyframe to `session` with its initial world pose (yaw + position; roll and
  /// pitch come from T_odom_b). A non-empty visual submap is added to the BoW database; its BoW
  /// vector goes to MapNode::bow, its keypoints to visualSubmap().
  /// Throws std::invalid_argument for an unknown session or a non-finite pose.
  PoseGraphNodeId addNode(double t, uint32_t session, const Eigen::Isometry3d& T_odom_b, const Eigen::Vector3d& p_w_b,
                          double yaw_w_b, VisualSubmap visual, bool magnetic_coverage);
  /// VIO relative pose between two nodes of one session (sigmas as PoseGraph4Dof: growing with
  /// distance, scaled by the drift learnt so far).
  void addSequentialEdge(PoseGraphNodeId from, PoseGraphNodeId to);
  /// Fits the VIO's drift from the loops within this run's sessions (odometry_drift.h) and
  /// re-weighs their sequential edges, and the ones added later, with it.
  const OdometryDriftFit& learnOdometryDrift();
  const OdometryDriftFit& odometryDrift() const { return drift_.fit(); }
  /// The weak "did not move far" edge from the last node of a session to the first of the next
  /// (zero relative motion, the given sigmas); joins their components.
  void addSessionLink(PoseGraphNodeId from, PoseGraphNodeId to, double sigma_position_m, double sigma_yaw_rad);
  /// A verified loop (T_match_query = pose of the query body in the match body frame). Joins
  /// the two components (call moveComponent first if the query's component is to be re-placed).
  /// `measurement_sigma`: the loop's own standard deviations of (p_li_j, yaw_i_j) (LoopAttempt::
  /// sigma), used with PoseGraphOptions::loop_sigma_from_inliers; NaN = none (constant sigmas).
  LoopEdgeId addLoopEdge(
      PoseGraphNodeId match, PoseGraphNodeId query, const Eigen::Isometry3d& T_match_query,
      const Eigen::Vector4d& measurement_sigma = Eigen::Vector4d::Constant(std::numeric_limits<double>::quiet_NaN()));
  /// A geomagnetic yaw factor from the low-passed geomagnetic field in the BODY frame. False
  /// when the field is not finite or its horizontal part is below mag_min_horizontal_field_tesla.
  /// The first accepted measurement of a component without loaded sessions rotates that
  /// component about its oldest keyframe to the measured heading (the VIO yaw is arbitrary; at
  /// 180 deg off the chordal residual has no gradient). A loaded map's frame is never rotated.
  bool addYawMeasurement(PoseGraphNodeId node, const Eigen::Vector3d& B_b_geomagnetic);
  /// Replaces the field of yaw measurement `index` (yawMeasurements()' order) by a better
  /// estimate of the same sample (the vehicle's own field taken out with a later fit); the
  /// component is not rotated again. False, leaving it as it was, when the new field's
  /// horizontal part is too small or not finite.
  bool setYawMeasurementField(size_t index, const Eigen::Vector3d& B_b_geomagnetic);
  /// A pressure depth of the port (p_b_port in the body) below the surface at `node`: a depth
  /// factor in the node's component solves (PoseGraph4Dof, DepthMeasurement). False for a
  /// non-finite depth. Depth factors belong to this run: the map file does not keep them.
  bool addDepthMeasurement(PoseGraphNodeId node, double depth_m, const Eigen::Vector3d& p_b_port);
  size_t numDepthMeasurements() const { return depth_measurements_.size(); }
  uint32_t addMagneticSubmap(const MagneticSubmapDraft& draft);
  void setMagneticCoverage(PoseGraphNodeId node, bool covered);

  // ---- components
  /// Representative of the node's connected component.
  uint32_t componentOf(PoseGraphNodeId node) const;
  bool sameComponent(PoseGraphNodeId a, PoseGraphNodeId b) const { return componentOf(a) == componentOf(b); }
  /// The component of node 0 (the loaded map's, or the run's first session's): the map frame.
  bool inReferenceComponent(PoseGraphNodeId node) const;
  bool componentHasLoadedSessions(uint32_t component) const;
  /// Applies a 4-DoF correction to every node of the component.
  void moveComponent(uint32_t component, const Correction4Dof& correction);

  // ---- optimisation
  /// Snapshot of the component containing `node`.
  ComponentSnapshot snapshotComponent(PoseGraphNodeId node) const;
  /// Writes a solution back: snapshot nodes take their optimised poses; nodes of the same
  /// component that were not in the snapshot (added or re-placed meanwhile) move with the
  /// correction of the last snapshot node of their session (or of the snapshot's last node).
  /// A failed solve changes nothing. Returns false when the solution does not fit the snapshot.
  bool applySolution(const ComponentSnapshot& snapshot, const PoseGraphSolution& solution);

  // ---- queries
  size_t numNodes() const { return nodes_.size(); }
  const MapNode& node(PoseGraphNodeId id) const { return nodes_.at(id); }
  /// The keypoints, descriptors and normalised coordinates of a keyframe's visual submap (its
  /// BoW vector is MapNode::bow; the returned one is empty); empty without a submap. A version-4
  /// map file's submaps stay in the mapped file until asked for: each call decodes the
  /// keyframe's block and checks its checksum (a corrupt block is logged and reads as empty).
  std::shared_ptr<const VisualSubmap> visualSubmap(PoseGraphNodeId id) const;
  const std::vector<MapNode>& nodes() const { return nodes_; }
  const std::vector<MapSession>& sessions() const { return sessions_; }
  const std::vector<SequentialEdge>& sequentialEdges() const { return sequential_edges_; }
  const std::vector<LoopEdge>& loopEdges() const { return loop_edges_; }
  const std::vector<YawMeasurement>& yawMeasurements() const { return yaw_measurements_; }
  const std::vector<MagneticSubmap>& magneticSubmaps() const { return magnetic_submaps_; }
  const BowDatabase* bowDatabase() const { return bow_.get(); }
  /// Node of a BoW image id.
  PoseGraphNodeId nodeOfImage(ImageId image) const { return image_to_node_.at(image); }
  const std::shared_ptr<const BinaryVocabulary>& vocabulary() const { return vocabulary_; }
  const PoseGraphOptions& graphOptions() const { return graph_options_; }

  Eigen::Isometry3d worldPose(PoseGraphNodeId id) const { return nodes_.at(id).pose.T_w_b(); }
  /// T_w_b T_odom_b^-1 at a node: the drift correction of its session (exactly 4-DoF).
  Eigen::Isometry3d T_map_odom(PoseGraphNodeId id) const;
  /// World position of a magnetic submap (its tied keyframe's).
  Eigen::Vector3d magneticSubmapPosition(const MagneticSubmap& submap) const;
  /// Which keyframes clusteredNodes() returns.
  enum class ClusterMembers {
    kVisualSubmaps,  ///< keyframes with a stored visual submap: the loop detector's candidates
    kBowVectors,     ///< also culled keyframes, which keep their BoW vector (evaluation)
  };
  /// Keyframes with a visual submap (or a BoW vector, see ClusterMembers) in the same component
  /// as the submap's tied keyframe whose horizontal world distance to the submap is at most
  /// radius + cluster_margin_m (ascending).
  std::vector<PoseGraphNodeId> clusteredNodes(const MagneticSubmap& submap, double cluster_margin_m,
                                              ClusterMembers members = ClusterMembers::kVisualSubmaps) const;

  // ---- persistence
  /// Writes the map (file format in docs/pose_graph.md) with the vocabulary reference (path as
  /// given + checksum). kLoadedSessions: the loaded sessions' keyframes with the edges, yaw
  /// factors and magnetic submaps among them only. `version`: kFileVersion, or 3 for a vehicle
  /// whose VIMS reads no later one. Throws std::runtime_error on an I/O error, and
  /// std::invalid_argument for a version it cannot write.
  void save(const std::string& path, const std::string& vocabulary_path, MapSaveScope scope = MapSaveScope::kAll,
            uint32_t version = kFileVersion) const;
  std::vector<uint8_t> serialize(const std::string& vocabulary_path, MapSaveScope scope = MapSaveScope::kAll,
                                 uint32_t version = kFileVersion) const;
  /// Loads a file into this map, which must be empty; every session becomes a loaded session.
  /// The file is mapped into memory and a version-4 file's visual submaps are read when asked
  /// for (visualSubmap), so a large map loads in the time of its poses and BoW vectors.
  /// Throws MapFileError (missing, truncated, corrupt, other version, inconsistent contents,
  /// descriptor type or vocabulary checksum differing from this map's vocabulary).
  void load(const std::string& path);
  void deserialize(const std::vector<uint8_t>& bytes, const std::string& source_name);

  /// FNV-1a 64 of the vocabulary's serialised bytes (0 without a vocabulary).
  uint64_t vocabularyChecksum() const { return vocabulary_checksum_; }

 private:
  /// The visual submaps of a version-4 file, left in its bytes (multiscale_map_file.cpp).
  struct PagedSubmaps;
  /// A file's bytes: mapped, or a copy (deserialize).
  struct FileBytes;

  /// Header, payload (index) and checksum, then (version 4) the keypoint blocks.
  void writeFile(MapFileWriter& w, const std::string& vocabulary_path, MapSaveScope scope, uint32_t version) const;
  /// The payload; version 4 with `block_checksums` (per node kept) instead of inline keypoints.
  void writePayload(MapFileWriter& w, const std::string& vocabulary_path, MapSaveScope scope, uint32_t version,
                    const std::vector<uint64_t>& block_checksums) const;
  /// Keyframes (a prefix of nodes_) that `scope` writes.
  size_t numNodesToWrite(MapSaveScope scope, uint32_t* num_sessions) const;
  /// A keyframe's keypoint records (kKeypointRecordBytes each) as the file stores them.
  void writeKeypointBlock(MapFileWriter& w, PoseGraphNodeId id) const;
  /// addNode with the submap's parts: its BoW vector, its keypoints' number, and the keypoints
  /// themselves (null when paged or none).
  PoseGraphNodeId appendNode(double t, uint32_t session, const Eigen::Isometry3d& T_odom_b,
                             const Eigen::Vector3d& p_w_b, double yaw_w_b, BowVector bow, uint32_t num_keypoints,
                             std::shared_ptr<const VisualSubmap> resident, bool magnetic_coverage);
  /// Parses a whole file held by `file` (kept by the map when its submaps stay paged).
  void parse(std::shared_ptr<const FileBytes> file, const std::string& source);
  uint32_t findSession(uint32_t session) const;
  void uniteSessions(uint32_t a, uint32_t b);
  void checkNode(PoseGraphNodeId id, const char* what) const;
  /// Indices of the sequential edges within one of this run's (not loaded) sessions.
  std::vector<size_t> runOdometryEdges() const;
  void applyCorrection(MapNode& n, const Correction4Dof& c) const;

  std::shared_ptr<const BinaryVocabulary> vocabulary_;
  uint64_t vocabulary_checksum_ = 0;
  PoseGraphOptions graph_options_;
  Eigen::Vector2d north_enu_;
  LoggerPtr logger_;
  std::unique_ptr<BowDatabase> bow_;
  std::vector<PoseGraphNodeId> image_to_node_;
  std::vector<MapNode> nodes_;
  /// Keypoints of nodes_[i] held in memory (built by this run, or read from a file before
  /// version 4); null when none or paged.
  std::vector<std::shared_ptr<const VisualSubmap>> resident_submaps_;
  /// The loaded file's visual submaps (version 4); null otherwise.
  std::shared_ptr<const PagedSubmaps> paged_;
  std::shared_ptr<const VisualSubmap> empty_submap_ = std::make_shared<const VisualSubmap>();
  std::vector<MapSession> sessions_;
  Eigen::Isometry3d run_T_b_c_ = Eigen::Isometry3d::Identity();
  std::vector<uint32_t> session_parent_;  ///< union-find over sessions; a root is its component's oldest session
  /// session_parent_ as the map file had it: the loaded sessions' components through their own
  /// edges only (MapSaveScope::kLoadedSessions; a run's loops may have joined them since).
  std::vector<uint32_t> loaded_session_parent_;
  std::vector<uint32_t> session_yaw_count_;
  std::vector<SequentialEdge> sequential_edges_;
  std::vector<LoopEdge> loop_edges_;
  LoopEdgeId next_loop_id_ = 0;
  OdometryDriftEstimator drift_;
  std::vector<YawMeasurement> yaw_measurements_;
  std::vector<DepthMeasurement> depth_measurements_;
  std::vector<MagneticSubmap> magnetic_submaps_;
};

/// Heap bytes a keyframe's visual submap holds once read (vector capacities: keypoints,
/// descriptors, normalised coordinates, and its BoW vector); what the map's memory grows by per
/// stored keyframe. Reads a paged submap from its file.
size_t visualSubmapMemoryBytes(const MultiScaleMap& map, PoseGraphNodeId id);

}  // namespace vims
