#include "core/common/allocator.hpp"

#include <cstdlib>  // defines __GLIBC__ on glibc

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace soilvol {

void KeepFreedMemoryForReuse() {
#if defined(__GLIBC__)
    constexpr int kMmapThresholdBytes = 32 << 20;  // glibc's largest (DEFAULT_MMAP_THRESHOLD_MAX)
    constexpr int kTrimThresholdBytes = 256 << 20;
    mallopt(M_MMAP_THRESHOLD, kMmapThresholdBytes);
    mallopt(M_TRIM_THRESHOLD, kTrimThresholdBytes);
#endif
}

}  // namespace soilvol
