// How this process's heap treats freed memory.
#pragma once

namespace linesight {

// Keeps freed blocks of up to 32 MiB in the heap for reuse instead of handing them back to the
// kernel. A live loop or a study allocates and frees the same large buffers every frame (isgm's
// superpixel and plane stages: ~17 MB a frame at 752x480); glibc returns blocks above its mmap
// threshold to the kernel on free, so each frame touched them afresh: ~4,400 page faults a frame,
// about 10 % of the matcher's time (measured with `linesight bench --chain`: 4,432 -> 11 faults per
// frame). The resident size stays at the process's high-water mark, which a live loop reaches on
// its first frame anyway. Process-wide: the CLI calls it once at start; a library never does.
void RetainFreedMemory();

}  // namespace linesight
