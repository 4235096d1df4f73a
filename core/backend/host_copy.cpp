#include "core/backend/host_copy.h"

#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/partitioner.h>

#include <algorithm>
#include <cstring>

namespace ff {

namespace {
// Below this a copy on one thread is over sooner than the other threads could be started.
constexpr std::size_t kParallelBytes = 256 * 1024;
constexpr std::size_t kChunk = 128 * 1024;
}  // namespace

void host_copy(void* dst, const void* src, std::size_t bytes) {
  if (bytes < kParallelBytes) {
    if (bytes) std::memcpy(dst, src, bytes);
    return;
  }
  auto* d = static_cast<unsigned char*>(dst);
  const auto* s = static_cast<const unsigned char*>(src);
  const std::size_t chunks = (bytes + kChunk - 1) / kChunk;
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, chunks, 1),
      [&](const tbb::blocked_range<std::size_t>& r) {
        const std::size_t begin = r.begin() * kChunk, end = std::min(bytes, r.end() * kChunk);
        std::memcpy(d + begin, s + begin, end - begin);
      },
      tbb::static_partitioner());
}

}  // namespace ff
