#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <memory>
#include <vector>

#include "vims_common/heap.h"

namespace {

/// Resident set of this process [MB] (/proc/self/statm, second field, in pages).
double residentMb() {
  std::ifstream statm("/proc/self/statm");
  long size = 0, resident = 0;
  statm >> size >> resident;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

}  // namespace

// 96 MB of small blocks (below the mmap threshold: they live in the arena) freed under a block
// still in use, so glibc cannot shrink the heap from its top by itself: the pages stay resident
// until they are handed back.
TEST(Heap, ReleaseFreeHeapPagesReturnsFreedPagesBelowALiveBlock) {
  constexpr std::size_t kBlocks = 96 * 1024;
  constexpr std::size_t kBlockBytes = 1024;
  std::vector<std::unique_ptr<char[]>> blocks;
  blocks.reserve(kBlocks);
  for (std::size_t i = 0; i < kBlocks; ++i) {
    blocks.emplace_back(new char[kBlockBytes]);
    std::memset(blocks.back().get(), 1, kBlockBytes);
  }
  std::unique_ptr<char[]> fence(new char[kBlockBytes]);
  std::memset(fence.get(), 1, kBlockBytes);
  blocks.clear();
  blocks.shrink_to_fit();
  const double retained = residentMb();
  if (!vims::releaseFreeHeapPages()) GTEST_SKIP() << "not glibc: nothing to release";
  const double released = residentMb();
  EXPECT_GT(retained - released, 48.0) << "RSS " << retained << " MB -> " << released << " MB";
  EXPECT_EQ(fence[0], 1);
}

TEST(Heap, PeriodicHeapReleaseReleasesOncePerPeriod) {
  vims::PeriodicHeapRelease release(60.0);
  EXPECT_TRUE(release.tick(1000.0));  // the first tick releases
  EXPECT_FALSE(release.tick(1000.0));
  EXPECT_FALSE(release.tick(1059.9));
  EXPECT_TRUE(release.tick(1060.0));
  EXPECT_FALSE(release.tick(1100.0));
  EXPECT_TRUE(release.tick(1120.0));
}
