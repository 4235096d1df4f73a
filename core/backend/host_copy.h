// Copies between host buffers that may be large (rollback snapshots, a stage's copy of the
// positions): one thread's memcpy reaches a fraction of the memory bandwidth, and the step
// waits for it, so big copies are split over the oneTBB threads. nvcc-clean (declaration only).
#pragma once
#include <cstddef>

namespace ff {

// memcpy(dst, src, bytes) (non-overlapping), in parallel chunks above a few hundred KiB.
void host_copy(void* dst, const void* src, std::size_t bytes);

}  // namespace ff
