#include "linesight/core/process_memory.h"

#include <malloc.h>

namespace linesight {

void RetainFreedMemory() {
#if defined(__GLIBC__)
  // 32 MiB is the largest mmap threshold glibc accepts on 64-bit; setting it also stops glibc
  // lowering it again. Trimming the heap top only above 1 GiB keeps freed blocks for reuse.
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
#endif
}

}  // namespace linesight
