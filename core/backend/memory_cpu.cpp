// The CPU backend's memory (core/backend/memory.h): host memory, copies at once, no fences.
#include <cstdlib>
#include <cstring>
#include <string>

#include "core/backend/host_copy.h"
#include "core/backend/memory.h"
#include "core/base/error.h"

namespace ff {

namespace {
void* host_alloc(std::size_t bytes) {
  if (bytes == 0) return nullptr;
  void* p = std::calloc(1, bytes);
  if (!p) throw RunError("out of host memory for stage scratch (" + std::to_string(bytes) + " bytes)");
  return p;
}
void host_release(void* p) { std::free(p); }
void copy(void* dst, const void* src, std::size_t bytes, CUstream_st*) { host_copy(dst, src, bytes); }
void host_fill(void* dst, int byte, std::size_t bytes, CUstream_st*) {
  if (bytes) std::memset(dst, byte, bytes);
}
void* no_fence() { return nullptr; }
void fence_nothing(void*) {}
void fence_record_nothing(void*, CUstream_st*) {}
}  // namespace

const MemoryOps& cpu_memory() {
  static const MemoryOps ops{&host_alloc, &host_release, &host_alloc,    &host_release,
                             &copy,       &copy,         &host_fill,     &copy,
                             &no_fence,   &fence_nothing, &fence_record_nothing, &fence_nothing};
  return ops;
}

}  // namespace ff
