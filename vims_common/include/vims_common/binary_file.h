#pragma once
/// @file binary_file.h
/// @brief Whole-file reads of the binary map and vocabulary files.

#include <cstdint>
#include <string>
#include <vector>

namespace vims {

/// The bytes of the file at `path`, read in one block (a byte-wise stream iterator reads a
/// 100 MB map at tens of MB/s; one read() at the disk's or the page cache's speed). Throws
/// std::runtime_error naming the path when it cannot be opened or read.
std::vector<uint8_t> readFileBytes(const std::string& path);

}  // namespace vims
