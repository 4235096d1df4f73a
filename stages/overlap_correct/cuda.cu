// CUDA loops of overlap_correct: element loops from core/cuda/loop.cuh and device memory.
// Compiled with -fmad=false (CMakeLists.txt): without contracted multiply-adds the kernels
// round exactly as the CPU loops do, so both backends produce the same bits in double.
#include <cuda_runtime.h>

#include "core/cuda/check.h"
#include "core/cuda/loop.cuh"
#include "stages/overlap_correct/cuda.cuh"

namespace ff::overlap {

namespace {
void* dev_alloc(std::size_t bytes) {
  if (bytes == 0) return nullptr;
  void* p = nullptr;
  FF_CUDA_CHECK(cudaMalloc(&p, bytes), "allocating overlap_correct scratch memory");
  return p;
}
void dev_release(void* p) {
  if (p) cudaFree(p);
}
void dev_zero(void* p, std::size_t bytes, CUstream_st* s) {
  if (bytes) FF_CUDA_CHECK(cudaMemsetAsync(p, 0, bytes, s), "clearing overlap_correct counters");
}
void dev_to_host(void* dst, const void* src, std::size_t bytes, CUstream_st* s) {
  if (!bytes) return;
  FF_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, s), "reading overlap_correct counters");
  FF_CUDA_CHECK(cudaStreamSynchronize(s), "waiting for overlap_correct counters");
}
}  // namespace

template <class R>
Ops<R> cuda_ops() {
  return {&cuda_for_each<Gather<R>>, &cuda_for_each<Apply<R>>, {&dev_alloc, &dev_release, &dev_zero, &dev_to_host}};
}
template Ops<float> cuda_ops<float>();
template Ops<double> cuda_ops<double>();

}  // namespace ff::overlap
