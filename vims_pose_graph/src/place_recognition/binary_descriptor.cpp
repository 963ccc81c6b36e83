#include "vims_pose_graph/binary_descriptor.h"

#include <cstring>
#include <stdexcept>
#include <string>

namespace vims {

BinaryDescriptor BinaryDescriptor::fromBytes(const uint8_t* bytes) {
  BinaryDescriptor d;
  std::memcpy(d.words.data(), bytes, kDescriptorBytes);
  return d;
}

void BinaryDescriptor::toBytes(uint8_t* bytes) const { std::memcpy(bytes, words.data(), kDescriptorBytes); }

std::vector<BinaryDescriptor> descriptorsFromMat(const cv::Mat& descriptors) {
  std::vector<BinaryDescriptor> out;
  if (descriptors.empty()) return out;
  if (descriptors.type() != CV_8UC1 || descriptors.cols != kDescriptorBytes) {
    throw std::invalid_argument("descriptorsFromMat: expected a CV_8UC1 matrix with " +
                                std::to_string(kDescriptorBytes) + " columns, got type " +
                                std::to_string(descriptors.type()) + " with " + std::to_string(descriptors.cols) +
                                " columns");
  }
  out.reserve(static_cast<size_t>(descriptors.rows));
  for (int r = 0; r < descriptors.rows; ++r) out.push_back(BinaryDescriptor::fromBytes(descriptors.ptr<uint8_t>(r)));
  return out;
}

cv::Mat descriptorsToMat(const std::vector<BinaryDescriptor>& descriptors) {
  cv::Mat out(static_cast<int>(descriptors.size()), kDescriptorBytes, CV_8UC1);
  for (size_t i = 0; i < descriptors.size(); ++i) descriptors[i].toBytes(out.ptr<uint8_t>(static_cast<int>(i)));
  return out;
}

BinaryDescriptor bitwiseMajority(const std::vector<BinaryDescriptor>& all, const std::vector<uint32_t>& indices) {
  // Count the set bits per position; only set bits are visited, which is about half the work
  // of testing all 256 positions.
  int counts[256] = {0};
  for (uint32_t idx : indices) {
    const BinaryDescriptor& d = all[idx];
    for (int w = 0; w < 4; ++w) {
      uint64_t x = d.words[static_cast<size_t>(w)];
      while (x != 0) {
        counts[w * 64 + __builtin_ctzll(x)]++;
        x &= x - 1;
      }
    }
  }
  BinaryDescriptor median;
  const size_t n = indices.size();
  for (int i = 0; i < 256; ++i) {
    if (2 * static_cast<size_t>(counts[i]) > n) median.setBit(i);
  }
  return median;
}

}  // namespace vims
