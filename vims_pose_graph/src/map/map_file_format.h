#pragma once
/// @file map_file_format.h
/// @brief The map file's layout (docs/pose_graph.md, "Map file"), shared by its writer
/// (multiscale_map_file_write.cpp) and reader (multiscale_map_file.cpp): constants, a checked
/// little-endian reader, the checksumming writer, and where a loaded file's keypoint blocks are.

#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <ostream>
#include <string>
#include <vector>

#include "vims_common/binary_file.h"
#include "vims_common/fnv1a.h"
#include "vims_pose_graph/multiscale_map.h"

namespace vims {

namespace map_file {

// Little-endian throughout. Versions 1-3: header, payload, FNV-1a 64 of all before it. Version
// 4: header (+ the blocks' size), payload (the index), FNV-1a 64 of header and index, then one
// block of keypoint records per keyframe with a submap, whose checksums are in the index.

inline constexpr char kMagic[8] = {'V', 'I', 'M', 'S', 'M', 'A', 'P', '\0'};
constexpr size_t kHeaderBytes = 8 + 4 + 8;  // magic, version, payload size
constexpr size_t kBlocksSizeBytes = 8;      // version 4: the keypoint blocks' size follows
/// A keypoint's record: pixel, size, angle, response (f32), octave (i32), normalised (f64 x 2),
/// descriptor.
constexpr size_t kKeypointRecordBytes = 6 * 4 + 16 + static_cast<size_t>(kDescriptorBytes);
/// Bounds far above any real map, so a corrupt count cannot request huge memory before the
/// reader runs out of bytes.
constexpr uint32_t kMaxCount = 100000000u;

/// Reads [begin, end) of `bytes`; every read past `end` or impossible value throws MapFileError
/// naming `source` and the offset.
class ByteReader {
 public:
  ByteReader(const uint8_t* bytes, size_t begin, size_t end, const std::string& source)
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
    std::string s(reinterpret_cast<const char*>(bytes_ + pos_), n);
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
    const uint8_t* p = bytes_ + pos_;
    pos_ += n;
    return p;
  }
  bool atEnd() const { return pos_ == end_; }

 private:
  const uint8_t* bytes_;
  size_t pos_;
  size_t end_;
  const std::string& source_;
};

}  // namespace map_file

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
  /// Flushes; returns the checksum of everything written so far.
  uint64_t flushedChecksum() {
    flush();
    return hash_;
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

struct MultiScaleMap::FileBytes {
  std::unique_ptr<const MappedFile> mapped;
  std::vector<uint8_t> copy;

  const uint8_t* data() const { return mapped ? mapped->data() : copy.data(); }
  size_t size() const { return mapped ? mapped->size() : copy.size(); }
};

struct MultiScaleMap::PagedSubmaps {
  std::shared_ptr<const FileBytes> file;
  std::string source;
  size_t blocks_begin = 0;         ///< file offset of the first keypoint block
  std::vector<uint64_t> offset;    ///< per loaded node: its block's offset from blocks_begin
  std::vector<uint64_t> checksum;  ///< per loaded node: FNV-1a 64 of its block
  /// Corrupt blocks already logged (each is logged once, however often a loop asks for it).
  mutable std::mutex reported_mutex;
  mutable std::vector<bool> reported;
};

}  // namespace vims
