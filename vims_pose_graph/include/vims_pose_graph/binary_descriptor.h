#pragma once
/// @file binary_descriptor.h
/// @brief 256-bit binary descriptors (ORB, BRIEF) as a fixed-size value type with Hamming
/// distance and the bitwise-majority median used by the vocabulary's k-medians.
///
/// The 32 bytes of a descriptor are kept in the byte order of the cv::Mat row they came from
/// (copied with memcpy), so the file format and cv::Mat round trips are byte-exact on any host;
/// the four 64-bit words are only a view for popcount.

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace vims {

/// Number of bytes of one descriptor (ORB and BRIEF-256 in VIMS).
constexpr int kDescriptorBytes = 32;

struct BinaryDescriptor {
  std::array<uint64_t, 4> words{{0, 0, 0, 0}};

  bool operator==(const BinaryDescriptor& o) const { return words == o.words; }
  bool operator!=(const BinaryDescriptor& o) const { return words != o.words; }
  bool operator<(const BinaryDescriptor& o) const { return words < o.words; }

  /// Bit `i` (0..255) in the view of the four words (the same bit index everywhere in VIMS).
  bool bit(int i) const { return (words[static_cast<size_t>(i >> 6)] >> (i & 63)) & 1u; }
  void setBit(int i) { words[static_cast<size_t>(i >> 6)] |= uint64_t{1} << (i & 63); }

  /// From / to 32 raw bytes.
  static BinaryDescriptor fromBytes(const uint8_t* bytes);
  void toBytes(uint8_t* bytes) const;
};

/// Marks a function whose loops compute many Hamming distances. Without a popcount instruction
/// in the target (x86-64's baseline has none), __builtin_popcountll becomes a libgcc call that
/// took two thirds of the loop detector's time. On x86-64 GCC builds the marked function twice,
/// with and without POPCNT, and the loader picks one for the CPU (ifunc), so the binary still
/// runs on CPUs without it. hammingDistance() must be inlined into such a function (it is
/// always_inline) to use the instruction; called from unmarked code it gives the same result.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__ELF__)
#define VIMS_POPCOUNT_DISPATCH __attribute__((target_clones("popcnt", "default")))
#else
#define VIMS_POPCOUNT_DISPATCH
#endif

/// Number of differing bits, 0..256.
__attribute__((always_inline)) inline int hammingDistance(const BinaryDescriptor& a, const BinaryDescriptor& b) {
  return __builtin_popcountll(a.words[0] ^ b.words[0]) + __builtin_popcountll(a.words[1] ^ b.words[1]) +
         __builtin_popcountll(a.words[2] ^ b.words[2]) + __builtin_popcountll(a.words[3] ^ b.words[3]);
}

/// Converts the rows of a CV_8UC1 matrix with 32 columns (what cv::ORB returns).
/// Throws std::invalid_argument for any other type or width; an empty matrix gives no descriptors.
std::vector<BinaryDescriptor> descriptorsFromMat(const cv::Mat& descriptors);
/// The inverse: an N x 32 CV_8UC1 matrix.
cv::Mat descriptorsToMat(const std::vector<BinaryDescriptor>& descriptors);

/// Bitwise majority of the given descriptors (the Hamming-space median of each bit).
/// A bit is set when strictly more than half of the members have it set; a tie gives 0.
/// `indices` selects members of `all`; an empty selection gives the zero descriptor.
BinaryDescriptor bitwiseMajority(const std::vector<BinaryDescriptor>& all, const std::vector<uint32_t>& indices);

}  // namespace vims
