#pragma once
/// @file fnv1a.h
/// @brief FNV-1a 64: the checksum of the map and vocabulary files and of the benches' outputs.

#include <cstddef>
#include <cstdint>

namespace vims {

inline constexpr uint64_t kFnv1a64OffsetBasis = 1469598103934665603ull;

/// FNV-1a 64 of `size` bytes, continuing from `h` (kFnv1a64OffsetBasis for a fresh hash).
inline uint64_t fnv1a64(const uint8_t* data, size_t size, uint64_t h = kFnv1a64OffsetBasis) {
  for (size_t i = 0; i < size; ++i) {
    h ^= data[i];
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace vims
