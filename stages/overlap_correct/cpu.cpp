// CPU loops of overlap_correct: oneTBB element loops (core/exec_cpu.h) and host memory.
#include <cstdlib>
#include <cstring>

#include "core/exec_cpu.h"
#include "stages/overlap_correct/cpu.h"

namespace ff::overlap {

namespace {
void* host_alloc(std::size_t bytes) {
  if (bytes == 0) return nullptr;
  void* p = std::calloc(1, bytes);
  if (!p) throw RunError("overlap_correct: out of host memory (" + std::to_string(bytes) + " bytes)");
  return p;
}
void host_release(void* p) { std::free(p); }
void host_zero(void* p, std::size_t bytes, CUstream_st*) {
  if (bytes) std::memset(p, 0, bytes);
}
void host_copy(void* dst, const void* src, std::size_t bytes, CUstream_st*) {
  if (bytes) std::memcpy(dst, src, bytes);
}
}  // namespace

template <class R>
Ops<R> cpu_ops() {
  return {&cpu_for_each<Gather<R>>, &cpu_for_each<Apply<R>>, {&host_alloc, &host_release, &host_zero, &host_copy}};
}
template Ops<float> cpu_ops<float>();
template Ops<double> cpu_ops<double>();

}  // namespace ff::overlap
