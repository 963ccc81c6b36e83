/// @file multiscale_map_file.cpp
/// @brief MultiScaleMap's map file: writing, reading and checking it (docs/pose_graph.md, "Map
/// file"). The map's contents and their building are in multiscale_map.cpp.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <limits>

#include "vims_common/binary_file.h"
#include "vims_common/fnv1a.h"
#include "vims_common/timing.h"
#include "vims_pose_graph/multiscale_map.h"

namespace vims {

namespace {
constexpr const char* kComponent = "pose_graph_map";
}  // namespace

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
    std::string s(bytes_.begin() + static_cast<std::ptrdiff_t>(pos_),
                  bytes_.begin() + static_cast<std::ptrdiff_t>(pos_ + n));
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
  uint64_t hash_ = kFnv1a64OffsetBasis;
};

void MultiScaleMap::writePayload(MapFileWriter& w, const std::string& vocabulary_path, MapSaveScope scope) const {
  w.str(vocabulary_ ? vocabulary_->descriptorType() : std::string());
  w.str(vocabulary_path);
  w.u64(vocabulary_checksum_);
  w.u64(vocabulary_ ? vocabulary_->numWords() : 0);

  // The loaded sessions come first and their keyframes are the first nodes (a map is loaded
  // before the run's first keyframe): kLoadedSessions writes those prefixes.
  uint32_t num_sessions = static_cast<uint32_t>(sessions_.size());
  if (scope == MapSaveScope::kLoadedSessions) {
    num_sessions = 0;
    while (num_sessions < sessions_.size() && sessions_[num_sessions].loaded) ++num_sessions;
  }
  size_t num_nodes = 0;
  while (num_nodes < nodes_.size() && nodes_[num_nodes].session < num_sessions) ++num_nodes;
  const auto kept = [num_nodes](PoseGraphNodeId id) { return id < num_nodes; };
  const std::vector<uint32_t>& parents =
      scope == MapSaveScope::kLoadedSessions ? loaded_session_parent_ : session_parent_;

  w.u32(num_sessions);
  for (uint32_t s = 0; s < num_sessions; ++s) {
    w.u32(sessions_[s].vio_session);
    w.u32(parents[s]);
    w.pose(sessions_[s].T_b_c);
  }
  w.u32(static_cast<uint32_t>(num_nodes));
  for (size_t node = 0; node < num_nodes; ++node) {
    const MapNode& n = nodes_[node];
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
  w.u32(static_cast<uint32_t>(std::count_if(sequential_edges_.begin(), sequential_edges_.end(),
                                            [&](const SequentialEdge& e) { return kept(e.from) && kept(e.to); })));
  for (const SequentialEdge& e : sequential_edges_) {
    if (!kept(e.from) || !kept(e.to)) continue;
    w.u32(e.from);
    w.u32(e.to);
    w.vec(e.measurement.p_li_j);
    w.f64(e.measurement.yaw_i_j);
    for (int i = 0; i < 4; ++i) w.f64(e.sqrt_information[i]);
  }
  w.u32(static_cast<uint32_t>(std::count_if(loop_edges_.begin(), loop_edges_.end(),
                                            [&](const LoopEdge& e) { return kept(e.match) && kept(e.query); })));
  for (const LoopEdge& e : loop_edges_) {
    if (!kept(e.match) || !kept(e.query)) continue;
    w.u32(e.id);
    w.u32(e.match);
    w.u32(e.query);
    w.pose(e.T_match_query);
    w.vec(e.measurement.p_li_j);
    w.f64(e.measurement.yaw_i_j);
    for (int i = 0; i < 4; ++i) w.f64(e.sqrt_information[i]);
    w.u8(e.enabled ? 1 : 0);
  }
  w.u32(static_cast<uint32_t>(std::count_if(yaw_measurements_.begin(), yaw_measurements_.end(),
                                            [&](const YawMeasurement& m) { return kept(m.node); })));
  for (const YawMeasurement& m : yaw_measurements_) {
    if (!kept(m.node)) continue;
    w.u32(m.node);
    w.f64(m.u_l.x());
    w.f64(m.u_l.y());
    w.f64(m.heading_rad);
  }
  w.u32(static_cast<uint32_t>(std::count_if(magnetic_submaps_.begin(), magnetic_submaps_.end(),
                                            [&](const MagneticSubmap& m) { return kept(m.tied_node); })));
  for (const MagneticSubmap& m : magnetic_submaps_) {
    if (!kept(m.tied_node)) continue;
    w.u32(m.tied_node);
    w.f64(m.t);
    w.u32(static_cast<uint32_t>(m.coil));
    w.vec(m.signature_enu);
    w.f64(m.radius_m);
    w.u32(m.num_members);
  }
}

void MultiScaleMap::writeFile(MapFileWriter& w, const std::string& vocabulary_path, MapSaveScope scope) const {
  MapFileWriter counter;
  writePayload(counter, vocabulary_path, scope);
  w.raw(reinterpret_cast<const uint8_t*>(kMagic), 8);
  w.u32(kFileVersion);
  w.u64(counter.size());
  writePayload(w, vocabulary_path, scope);
  w.finishWithChecksum();
}

std::vector<uint8_t> MultiScaleMap::serialize(const std::string& vocabulary_path, MapSaveScope scope) const {
  std::vector<uint8_t> bytes;
  MapFileWriter w(&bytes);
  writeFile(w, vocabulary_path, scope);
  return bytes;
}

void MultiScaleMap::save(const std::string& path, const std::string& vocabulary_path, MapSaveScope scope) const {
  // Write to a temporary file and rename, so a crash mid-write never leaves a half map under
  // the real name.
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot write map file '" + tmp + "'");
    MapFileWriter w(&out);
    writeFile(w, vocabulary_path, scope);
    out.flush();
    if (!out) throw std::runtime_error("I/O error writing map file '" + tmp + "'");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error("cannot rename '" + tmp + "' to map file '" + path + "'");
}

void MultiScaleMap::load(const std::string& path) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<uint8_t> bytes;
  try {
    bytes = readFileBytes(path);
  } catch (const std::runtime_error& e) {
    throw MapFileError(std::string("map file ") + e.what());
  }
  const double read_s = 1e-3 * millisecondsSince(start);
  deserialize(bytes, path);
  logger_->info(kComponent,
                VIMS_STR(std::fixed << std::setprecision(2) << "map file '" << path
                                    << "': " << 1e-6 * static_cast<double>(bytes.size()) << " MB loaded in "
                                    << 1e-3 * millisecondsSince(start) << " s (" << read_s << " s of it reading)"));
}

namespace {

/// Checks the file's magic, version, sizes and checksum; returns the payload's end (the
/// checksum's offset + 8). Throws MapFileError naming `source`.
uint64_t checkedFileSize(const std::vector<uint8_t>& bytes, const std::string& source, uint32_t* version_out) {
  auto fail = [&](const std::string& what) -> MapFileError {
    return MapFileError("map file '" + source + "': " + what);
  };
  if (bytes.size() < kHeaderBytes + 8) throw fail("truncated (" + std::to_string(bytes.size()) + " bytes)");
  if (std::memcmp(bytes.data(), kMagic, 8) != 0) throw fail("not a VIMS map (bad magic)");
  uint32_t version = 0;
  for (int i = 0; i < 4; ++i) version |= static_cast<uint32_t>(bytes[8 + static_cast<size_t>(i)]) << (8 * i);
  if (version < 1 || version > MultiScaleMap::kFileVersion)
    throw fail("unsupported version " + std::to_string(version) + " (this build reads 1 to " +
               std::to_string(MultiScaleMap::kFileVersion) + ")");
  *version_out = version;
  uint64_t payload = 0;
  for (int i = 0; i < 8; ++i) payload |= static_cast<uint64_t>(bytes[12 + static_cast<size_t>(i)]) << (8 * i);
  const uint64_t expected = kHeaderBytes + payload + 8;
  if (payload > bytes.size() || expected > bytes.size())
    throw fail("truncated (" + std::to_string(bytes.size()) + " of " + std::to_string(expected) + " bytes)");
  if (expected < bytes.size())
    throw fail("oversized (" + std::to_string(bytes.size()) + " bytes, header says " + std::to_string(expected) + ")");
  uint64_t stored_checksum = 0;
  for (int i = 0; i < 8; ++i)
    stored_checksum |= static_cast<uint64_t>(bytes[expected - 8 + static_cast<size_t>(i)]) << (8 * i);
  if (fnv1a64(bytes.data(), expected - 8) != stored_checksum) throw fail("checksum mismatch (file corrupt)");

  return expected;
}

/// A keyframe's keypoints, their descriptors and its BoW vector.
VisualSubmap readVisualSubmap(ByteReader& r, size_t num_words) {
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
  return v;
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

void MultiScaleMap::deserialize(const std::vector<uint8_t>& bytes, const std::string& source) {
  if (!nodes_.empty() || !sessions_.empty())
    throw std::logic_error("MultiScaleMap::deserialize: the map must be empty (load before feeding keyframes)");
  auto fail = [&](const std::string& what) -> MapFileError {
    return MapFileError("map file '" + source + "': " + what);
  };
  uint32_t version = 0;
  const uint64_t expected = checkedFileSize(bytes, source, &version);
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
  for (uint32_t i = 0; i < num_nodes; ++i) {
    const double t = r.finite("keyframe time");
    const uint32_t session = r.u32();
    if (session >= num_sessions) r.fail("corrupt: keyframe session out of range");
    const Eigen::Isometry3d T_odom_b = r.pose("keyframe VIO pose");
    const Eigen::Vector3d p_w_b = r.vec("keyframe world position");
    const double yaw_w_b = r.finite("keyframe world yaw");
    const bool coverage = r.u8() != 0;
    VisualSubmap v = readVisualSubmap(r, num_words);
    m.addNode(t, session, T_odom_b, p_w_b, yaw_w_b, std::move(v), coverage);
  }
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
  logger_->info(kComponent, VIMS_STR("loaded map '" << source << "': " << nodes_.size() << " keyframes, "
                                                    << sessions_.size() << " sessions, " << loop_edges_.size()
                                                    << " loops, " << magnetic_submaps_.size() << " magnetic submaps"));
  if (version < 3)
    logger_->warn(kComponent,
                  VIMS_STR("map file '" << source << "' (version " << version
                                        << ") does not record its camera extrinsic: this run's is assumed"));
}

}  // namespace vims
