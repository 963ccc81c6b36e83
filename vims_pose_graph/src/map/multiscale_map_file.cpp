/// @file multiscale_map_file.cpp
/// @brief MultiScaleMap's map file: reading and checking it, and the visual submaps a version-4
/// file leaves in the mapped file (docs/pose_graph.md, "Map file"). Writing it is in
/// multiscale_map_file_write.cpp; the map's contents and their building in multiscale_map.cpp.
#include <algorithm>
#include <iomanip>
#include <limits>

#include "map_file_format.h"
#include "vims_common/timing.h"

namespace vims {

using namespace map_file;

namespace {
constexpr const char* kComponent = "pose_graph_map";
}  // namespace

void MultiScaleMap::load(const std::string& path) {
  const auto start = std::chrono::steady_clock::now();
  auto file = std::make_shared<FileBytes>();
  try {
    file->mapped = std::make_unique<const MappedFile>(path);
  } catch (const std::runtime_error& e) {
    throw MapFileError(std::string("map file ") + e.what());
  }
  const double size_mb = 1e-6 * static_cast<double>(file->size());
  parse(std::move(file), path);
  logger_->info(kComponent, VIMS_STR(std::fixed << std::setprecision(2) << "map file '" << path << "': " << size_mb
                                                << " MB loaded in " << 1e-3 * millisecondsSince(start) << " s"
                                                << (paged_ ? " (visual submaps read from the file when needed)" : "")));
}

void MultiScaleMap::deserialize(const std::vector<uint8_t>& bytes, const std::string& source) {
  auto file = std::make_shared<FileBytes>();
  file->copy = bytes;
  parse(std::move(file), source);
}

namespace {

/// Where a checked file's parts lie.
struct FileLayout {
  uint32_t version = 0;
  size_t payload_end = 0;   ///< the payload (index) is [kHeaderBytes(+8), payload_end)
  size_t blocks_begin = 0;  ///< version 4: the keypoint blocks, to the end of the file
  uint64_t blocks_size = 0;
};

uint64_t readLittleEndian64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(p[i]) << (8 * i);
  return v;
}

/// Checks the file's magic, version, sizes and checksum (versions 1-3: of the whole file;
/// 4: of the header and index, the blocks being checked when read). Throws MapFileError naming
/// `source`.
FileLayout checkedLayout(const uint8_t* bytes, size_t size, const std::string& source) {
  auto fail = [&](const std::string& what) -> MapFileError {
    return MapFileError("map file '" + source + "': " + what);
  };
  if (size < kHeaderBytes + 8) throw fail("truncated (" + std::to_string(size) + " bytes)");
  if (std::memcmp(bytes, kMagic, 8) != 0) throw fail("not a VIMS map (bad magic)");
  FileLayout layout;
  for (int i = 0; i < 4; ++i) layout.version |= static_cast<uint32_t>(bytes[8 + i]) << (8 * i);
  if (layout.version < 1 || layout.version > MultiScaleMap::kFileVersion)
    throw fail("unsupported version " + std::to_string(layout.version) + " (this build reads 1 to " +
               std::to_string(MultiScaleMap::kFileVersion) + ")");
  const uint64_t payload = readLittleEndian64(bytes + 12);
  const bool blocks = layout.version >= 4;
  const size_t header = kHeaderBytes + (blocks ? kBlocksSizeBytes : 0);
  if (size < header + 8) throw fail("truncated (" + std::to_string(size) + " bytes)");
  layout.blocks_size = blocks ? readLittleEndian64(bytes + kHeaderBytes) : 0;
  if (payload > size || layout.blocks_size > size || header + payload + 8 + layout.blocks_size > size)
    throw fail("truncated (" + std::to_string(size) + " bytes, header says " +
               std::to_string(header + payload + 8 + layout.blocks_size) + ")");
  const uint64_t expected = header + payload + 8 + layout.blocks_size;
  if (expected < size)
    throw fail("oversized (" + std::to_string(size) + " bytes, header says " + std::to_string(expected) + ")");
  layout.payload_end = static_cast<size_t>(header + payload);
  layout.blocks_begin = layout.payload_end + 8;
  if (fnv1a64(bytes, layout.payload_end) != readLittleEndian64(bytes + layout.payload_end))
    throw fail("checksum mismatch (file corrupt)");
  return layout;
}

/// `count` keypoint records (kKeypointRecordBytes each) into `v`.
void readKeypoints(ByteReader& r, uint32_t count, VisualSubmap* v) {
  v->keypoints.reserve(count);
  v->normalized.reserve(count);
  v->descriptors.reserve(count);
  for (uint32_t k = 0; k < count; ++k) {
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
    v->keypoints.push_back(kp);
    v->normalized.emplace_back(nx, ny);
    v->descriptors.push_back(BinaryDescriptor::fromBytes(r.take(kDescriptorBytes)));
  }
}

BowVector readBowVector(ByteReader& r, size_t num_words) {
  BowVector bow;
  const uint32_t num_entries = r.count(12, "BoW entries");
  bow.entries.reserve(num_entries);
  for (uint32_t k = 0; k < num_entries; ++k) {
    BowEntry e;
    e.word = r.u32();
    e.weight = r.finite("BoW weight");
    if (e.word >= num_words || !(e.weight > 0.0)) r.fail("corrupt: BoW entry outside the vocabulary");
    if (!bow.entries.empty() && e.word <= bow.entries.back().word) r.fail("corrupt: BoW entries not sorted");
    bow.entries.push_back(e);
  }
  return bow;
}

SequentialEdge readSequentialEdge(ByteReader& r, uint32_t num_nodes) {
  SequentialEdge e;
  e.from = r.u32();
  e.to = r.u32();
  if (e.from >= num_nodes || e.to >= num_nodes || e.from == e.to) r.fail("corrupt: sequential edge node out of range");
  e.measurement.p_li_j = r.vec("sequential edge");
  e.measurement.yaw_i_j = r.finite("sequential edge");
  for (int k = 0; k < 4; ++k) e.sqrt_information[k] = r.finite("sequential edge information");
  if ((e.sqrt_information.array() <= 0.0).any()) r.fail("corrupt: non-positive edge information");
  return e;
}

LoopEdge readLoopEdge(ByteReader& r, uint32_t num_nodes) {
  LoopEdge e;
  e.id = r.u32();
  e.match = r.u32();
  e.query = r.u32();
  if (e.match >= num_nodes || e.query >= num_nodes || e.match == e.query)
    r.fail("corrupt: loop edge node out of range");
  e.T_match_query = r.pose("loop edge");
  e.measurement.p_li_j = r.vec("loop edge");
  e.measurement.yaw_i_j = r.finite("loop edge");
  for (int k = 0; k < 4; ++k) e.sqrt_information[k] = r.finite("loop edge information");
  if ((e.sqrt_information.array() <= 0.0).any()) r.fail("corrupt: non-positive edge information");
  e.enabled = r.u8() != 0;
  return e;
}

YawMeasurement readYawMeasurement(ByteReader& r, uint32_t num_nodes) {
  YawMeasurement y;
  y.node = r.u32();
  if (y.node >= num_nodes) r.fail("corrupt: yaw factor node out of range");
  y.u_l.x() = r.finite("yaw factor");
  y.u_l.y() = r.finite("yaw factor");
  y.heading_rad = r.finite("yaw factor");
  if (std::abs(y.u_l.norm() - 1.0) > 1e-6) r.fail("corrupt: yaw factor direction is not a unit vector");
  return y;
}

/// Version 1 has no coil index (one coil: 0).
MagneticSubmapDraft readMagneticSubmap(ByteReader& r, uint32_t num_nodes, uint32_t version) {
  MagneticSubmapDraft d;
  d.tied_node = r.u32();
  if (d.tied_node >= num_nodes) r.fail("corrupt: magnetic submap keyframe out of range");
  d.t = r.finite("magnetic submap");
  if (version >= 2) {
    const uint32_t coil = r.u32();
    if (coil > static_cast<uint32_t>(kMaxCoilIndex))
      r.fail("corrupt: magnetic submap coil index " + std::to_string(coil));
    d.coil = static_cast<int>(coil);
  }
  d.signature_enu = r.vec("magnetic submap signature");
  d.radius_m = r.finite("magnetic submap radius");
  if (!(d.radius_m >= 0.0)) r.fail("corrupt: negative magnetic submap radius");
  d.num_members = r.u32();
  return d;
}

}  // namespace

void MultiScaleMap::parse(std::shared_ptr<const FileBytes> file, const std::string& source) {
  if (!nodes_.empty() || !sessions_.empty())
    throw std::logic_error("MultiScaleMap::deserialize: the map must be empty (load before feeding keyframes)");
  auto fail = [&](const std::string& what) -> MapFileError {
    return MapFileError("map file '" + source + "': " + what);
  };
  const FileLayout layout = checkedLayout(file->data(), file->size(), source);
  const uint32_t version = layout.version;
  const size_t payload_begin = kHeaderBytes + (version >= 4 ? kBlocksSizeBytes : 0);
  ByteReader r(file->data(), payload_begin, layout.payload_end, source);
  const std::string descriptor_type = r.str(64);
  const std::string vocabulary_path = r.str(4096);
  const uint64_t vocabulary_checksum = r.u64();
  const uint64_t vocabulary_words = r.u64();
  const std::string own_type = vocabulary_ ? vocabulary_->descriptorType() : std::string();
  if (descriptor_type != own_type)
    throw fail("built with '" + descriptor_type + "' descriptors, but this run uses '" + own_type +
               "' (the map's loop closing mode must use the same descriptor)");
  if (vocabulary_checksum != vocabulary_checksum_)
    throw fail("built with another vocabulary ('" + vocabulary_path + "', checksum " +
               std::to_string(vocabulary_checksum) + "); this run's vocabulary has checksum " +
               std::to_string(vocabulary_checksum_));
  (void)vocabulary_words;

  // Parse into a fresh map first: nothing of this map changes unless the whole file is valid.
  MultiScaleMap m(vocabulary_, graph_options_, 0.0, logger_);
  m.north_enu_ = north_enu_;
  m.run_T_b_c_ = run_T_b_c_;  // the camera of a file that does not record its own (version < 3)
  const uint32_t num_sessions = r.count(8 + (version >= 3 ? 96 : 0), "sessions");
  std::vector<uint32_t> parents(num_sessions);
  for (uint32_t s = 0; s < num_sessions; ++s) {
    const uint32_t vio = r.u32();
    parents[s] = r.u32();
    if (parents[s] >= num_sessions || parents[s] > s) r.fail("corrupt: session parent out of range");
    m.addSession(vio, true);
    if (version >= 3) m.sessions_.back().T_b_c = r.pose("session camera extrinsic");
  }

  const uint32_t num_nodes = r.count(8 + 4 + 96 + 24 + 8 + 1 + 8, "keyframes");
  const size_t num_words = vocabulary_ ? vocabulary_->numWords() : 0;
  auto paged = std::make_shared<PagedSubmaps>();
  uint64_t block_offset = 0;
  for (uint32_t i = 0; i < num_nodes; ++i) {
    const double t = r.finite("keyframe time");
    const uint32_t session = r.u32();
    if (session >= num_sessions) r.fail("corrupt: keyframe session out of range");
    const Eigen::Isometry3d T_odom_b = r.pose("keyframe VIO pose");
    const Eigen::Vector3d p_w_b = r.vec("keyframe world position");
    const double yaw_w_b = r.finite("keyframe world yaw");
    const bool coverage = r.u8() != 0;
    if (version < 4) {
      VisualSubmap v;
      readKeypoints(r, r.count(kKeypointRecordBytes, "keypoints"), &v);
      v.bow = readBowVector(r, num_words);
      m.addNode(t, session, T_odom_b, p_w_b, yaw_w_b, std::move(v), coverage);
      continue;
    }
    const uint32_t num_keypoints = r.u32();
    const uint64_t checksum = r.u64();
    const uint64_t block_bytes = uint64_t{num_keypoints} * kKeypointRecordBytes;
    if (block_bytes > layout.blocks_size - block_offset)
      r.fail("corrupt: keypoint blocks run past the end of the file");
    paged->offset.push_back(block_offset);
    paged->checksum.push_back(checksum);
    block_offset += block_bytes;
    m.appendNode(t, session, T_odom_b, p_w_b, yaw_w_b, readBowVector(r, num_words), num_keypoints, nullptr, coverage);
  }
  if (version >= 4 && block_offset != layout.blocks_size)
    throw fail("corrupt: the keypoint blocks (" + std::to_string(layout.blocks_size) +
               " bytes) are not the keyframes' (" + std::to_string(block_offset) + " bytes)");
  const uint32_t num_sequential = r.count(8 + 32 + 32, "sequential edges");
  for (uint32_t i = 0; i < num_sequential; ++i) {
    m.sequential_edges_.push_back(readSequentialEdge(r, num_nodes));
  }
  const uint32_t num_loops = r.count(12 + 96 + 32 + 32 + 1, "loop edges");
  for (uint32_t i = 0; i < num_loops; ++i) {
    const LoopEdge e = readLoopEdge(r, num_nodes);
    m.loop_edges_.push_back(e);
    m.next_loop_id_ = std::max(m.next_loop_id_, e.id + 1);
  }
  const uint32_t num_yaw = r.count(4 + 24, "yaw factors");
  for (uint32_t i = 0; i < num_yaw; ++i) {
    const YawMeasurement y = readYawMeasurement(r, num_nodes);
    m.yaw_measurements_.push_back(y);
    ++m.session_yaw_count_[m.nodes_[y.node].session];
  }
  const uint32_t num_magnetic = r.count(4 + 8 + (version >= 2 ? 4 : 0) + 24 + 8 + 4, "magnetic submaps");
  for (uint32_t i = 0; i < num_magnetic; ++i) {
    m.addMagneticSubmap(readMagneticSubmap(r, num_nodes, version));
  }
  if (!r.atEnd()) r.fail("corrupt: trailing bytes in the payload");
  m.session_parent_ = parents;
  // Sessions are linked only through their edges; the union-find of the file must agree.
  for (uint32_t s = 0; s < num_sessions; ++s)
    if (m.sessions_[s].num_nodes == 0) r.fail("corrupt: empty session");

  nodes_ = std::move(m.nodes_);
  sessions_ = std::move(m.sessions_);
  session_parent_ = std::move(m.session_parent_);
  loaded_session_parent_ = session_parent_;
  session_yaw_count_ = std::move(m.session_yaw_count_);
  sequential_edges_ = std::move(m.sequential_edges_);
  loop_edges_ = std::move(m.loop_edges_);
  next_loop_id_ = m.next_loop_id_;
  yaw_measurements_ = std::move(m.yaw_measurements_);
  magnetic_submaps_ = std::move(m.magnetic_submaps_);
  bow_ = std::move(m.bow_);
  image_to_node_ = std::move(m.image_to_node_);
  resident_submaps_ = std::move(m.resident_submaps_);
  if (version >= 4) {
    paged->file = std::move(file);
    paged->source = source;
    paged->blocks_begin = layout.blocks_begin;
    paged->reported.assign(num_nodes, false);
    paged_ = std::move(paged);
  }
  logger_->info(kComponent, VIMS_STR("loaded map '" << source << "': " << nodes_.size() << " keyframes, "
                                                    << sessions_.size() << " sessions, " << loop_edges_.size()
                                                    << " loops, " << magnetic_submaps_.size() << " magnetic submaps"));
  if (version < 3)
    logger_->warn(kComponent,
                  VIMS_STR("map file '" << source << "' (version " << version
                                        << ") does not record its camera extrinsic: this run's is assumed"));
}

std::shared_ptr<const VisualSubmap> MultiScaleMap::visualSubmap(PoseGraphNodeId id) const {
  const MapNode& n = nodes_.at(id);
  if (resident_submaps_[id]) return resident_submaps_[id];
  if (!n.hasVisualSubmap() || !paged_ || id >= paged_->offset.size()) return empty_submap_;
  const PagedSubmaps& paged = *paged_;
  const uint8_t* block = paged.file->data() + paged.blocks_begin + paged.offset[id];
  const size_t size = n.num_keypoints * kKeypointRecordBytes;
  std::string problem;
  if (fnv1a64(block, size) != paged.checksum[id]) {
    problem = "checksum mismatch";
  } else {
    auto v = std::make_shared<VisualSubmap>();
    try {
      ByteReader r(block, 0, size, paged.source);
      readKeypoints(r, n.num_keypoints, v.get());
      return v;
    } catch (const MapFileError& e) {
      problem = e.what();
    }
  }
  // Defined behaviour for a block corrupted after the map was saved: the keyframe cannot be a
  // loop's match (as one without corners), the rest of the map works.
  std::lock_guard<std::mutex> lock(paged.reported_mutex);
  if (!paged.reported[id]) {
    paged.reported[id] = true;
    logger_->error(kComponent,
                   VIMS_STR("map file '" << paged.source << "': the visual submap of keyframe " << id << " is corrupt ("
                                         << problem << "); it is left out of loop closing"));
  }
  return empty_submap_;
}

}  // namespace vims
