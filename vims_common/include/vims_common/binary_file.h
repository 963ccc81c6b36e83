#pragma once
/// @file binary_file.h
/// @brief Whole-file access to the binary map and vocabulary files: read in one block, or
/// mapped into memory.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vims {

/// The bytes of the file at `path`, read in one block (a byte-wise stream iterator reads a
/// 100 MB map at tens of MB/s; one read() at the disk's or the page cache's speed). Throws
/// std::runtime_error naming the path when it cannot be opened or read.
std::vector<uint8_t> readFileBytes(const std::string& path);

/// A whole file mapped read-only into memory: its pages come from the disk (or the page cache)
/// when first touched, so opening a large map costs only the parts read. The mapping keeps the
/// file's contents as they were when opened as long as the file is replaced by a rename (as
/// MultiScaleMap::save does); truncating the mapped file in place is undefined.
class MappedFile {
 public:
  /// Throws std::runtime_error naming the path when it cannot be opened or mapped.
  explicit MappedFile(const std::string& path);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  /// Null for an empty file.
  const uint8_t* data() const { return data_; }
  size_t size() const { return size_; }

 private:
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
};

}  // namespace vims
