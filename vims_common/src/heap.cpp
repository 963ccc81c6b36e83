#include "vims_common/heap.h"

#include <cstdlib>  // defines __GLIBC__ with glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace vims {

bool releaseFreeHeapPages() {
#if defined(__GLIBC__)
  malloc_trim(0);
  return true;
#else
  return false;
#endif
}

bool PeriodicHeapRelease::tick(double now_s) {
  if (released_once_ && now_s - last_s_ < period_s_) return false;
  released_once_ = true;
  last_s_ = now_s;
  releaseFreeHeapPages();
  return true;
}

}  // namespace vims
