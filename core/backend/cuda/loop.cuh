// The CUDA element loops and reductions, and CudaExec, the backend object of CUDA stages.
// Include only from .cu files. Launches on the stream the core gave the stage (never the default
// stream) and checks the launch (FF_CUDA_CHECK_LAUNCH).
#pragma once
#include <cuda_runtime.h>

#include <cstdint>

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/pdl.cuh"
#include "core/backend/exec.h"
#include "core/backend/field.h"
#include "core/backend/memory.h"

namespace ff {

// The loops and reductions below: one element a thread, in blocks of kLoopThreads.
constexpr int kLoopThreads = 256;
inline unsigned loop_blocks(std::size_t n) { return unsigned((n + kLoopThreads - 1) / kLoopThreads); }
// This thread's element (n or more for the last block's spare threads).
__device__ __forceinline__ std::size_t loop_element() { return std::size_t(blockIdx.x) * blockDim.x + threadIdx.x; }

template <class F>
__global__ void for_each_kernel(std::size_t n, F f) {
  const std::size_t i = loop_element();
  if (i < n) f(i);
}

template <class F>
void cuda_for_each(std::size_t n, const F& f, CUstream_st* stream) {
  if (n == 0) return;
  for_each_kernel<F><<<loop_blocks(n), kLoopThreads, 0, stream>>>(n, f);
  FF_CUDA_CHECK_LAUNCH("launching an element loop");
}

// An element loop launched after the previous kernel programmatically (pdl.cuh): scheduled while
// that kernel runs, it waits for it before it reads anything, and lets the next kernel be scheduled
// while it runs. The overdamped integrators' loop uses it (the first kernel of a step, so it may be
// scheduled while the last step's final kernel runs, and detect_inversion's marking while it runs),
// and so do Lawson's grid rounds (a large step's rounds: three kernels a round).
template <class F>
__global__ void after_previous_kernel(std::size_t n, F f) {
  wait_for_previous_kernel();
  allow_next_kernel();
  const std::size_t i = loop_element();
  if (i < n) f(i);
}

// `what` names the launch in the error a failed launch throws.
template <class F>
void cuda_for_each_after_previous(const char* what, std::size_t n, const F& f, CUstream_st* stream) {
  if (n == 0) return;
  launch_after_previous(what, after_previous_kernel<F>, dim3(loop_blocks(n)), dim3(kLoopThreads), stream, n, f);
}

// cuda_for_each with __launch_bounds__(kLoopThreads, MinBlocks): registers capped so that MinBlocks
// blocks fit on an SM. For a memory-bound loop whose occupancy the default allocation limits
// (measure first: a cap that forces spills usually loses).
template <class F, int MinBlocks>
__global__ void __launch_bounds__(kLoopThreads, MinBlocks) for_each_bounded_kernel(std::size_t n, F f) {
  const std::size_t i = loop_element();
  if (i < n) f(i);
}

template <class F, int MinBlocks>
void cuda_for_each_bounded(std::size_t n, const F& f, CUstream_st* stream) {
  if (n == 0) return;
  for_each_bounded_kernel<F, MinBlocks><<<loop_blocks(n), kLoopThreads, 0, stream>>>(n, f);
  FF_CUDA_CHECK_LAUNCH("launching an element loop");
}

// Reductions (CudaExec::max, sum, count): each warp combines its lanes' values, and one lane
// per warp combines them into the result word with an integer atomic, which the host reads
// back. Integer max and sum do not depend on the order of the atomics.
template <class F>
__global__ void reduce_max_kernel(std::size_t n, F f, std::uint32_t* out) {
  const std::size_t i = loop_element();
  std::uint32_t v = i < n ? std::uint32_t(f(i)) : 0u;
  for (int o = 16; o > 0; o >>= 1) v = max(v, __shfl_down_sync(0xffffffffu, v, o));
  if ((threadIdx.x & 31) == 0 && v) atomicMax(out, v);
}

template <class F, bool Count>
__global__ void reduce_sum_kernel(std::size_t n, F f, std::uint64_t* out) {
  const std::size_t i = loop_element();
  unsigned long long v = 0;
  if (i < n) v = Count ? (f(i) ? 1ull : 0ull) : static_cast<unsigned long long>(f(i));
  for (int o = 16; o > 0; o >>= 1) v += __shfl_down_sync(0xffffffffu, v, o);
  if ((threadIdx.x & 31) == 0 && v) atomicAdd(reinterpret_cast<unsigned long long*>(out), v);
}

template <class F>
std::uint32_t cuda_max(std::size_t n, const F& f, Reduction<std::uint32_t>& r, CUstream_st* stream) {
  if (n == 0) return 0;
  std::uint32_t* word = r.clear(0, stream);
  reduce_max_kernel<F><<<loop_blocks(n), kLoopThreads, 0, stream>>>(n, f, word);
  FF_CUDA_CHECK_LAUNCH("launching a max-reduction");
  return r.read(stream);
}

template <class F, bool Count>
std::uint64_t cuda_sum(std::size_t n, const F& f, Reduction<std::uint64_t>& r, CUstream_st* stream) {
  if (n == 0) return 0;
  std::uint64_t* word = r.clear(0, stream);
  reduce_sum_kernel<F, Count><<<loop_blocks(n), kLoopThreads, 0, stream>>>(n, f, word);
  FF_CUDA_CHECK_LAUNCH(Count ? "launching a count-reduction" : "launching a sum-reduction");
  return r.read(stream);
}

// The CUDA backend object a stage template's constructor receives (core/stage/stage_registration.h);
// the members are CpuExec's (core/backend/exec_cpu.h), which says what each does.
struct CudaExec {
  static constexpr Backend backend = Backend::cuda;
  static constexpr Where where = Where::device;
  static const MemoryOps& memory() { return cuda_memory(); }
  template <class F>
  static void for_each(std::size_t n, const F& f, CUstream_st* s) { cuda_for_each(n, f, s); }
  template <class F, int MinBlocks>
  static void for_each_bounded(std::size_t n, const F& f, CUstream_st* s) { cuda_for_each_bounded<F, MinBlocks>(n, f, s); }
  // The overdamped integrators (core/physics/overdamped.h): one particle per thread (F::operator()).
  template <class F>
  static void overdamped(std::size_t n, const F& f, CUstream_st* s) {
    cuda_for_each_after_previous("launching an integrator's loop", n, f, s);
  }
  template <class F>
  static std::uint32_t max(std::size_t n, const F& f, Reduction<std::uint32_t>& r, CUstream_st* s) {
    return cuda_max(n, f, r, s);
  }
  template <class F>
  static std::uint64_t sum(std::size_t n, const F& f, Reduction<std::uint64_t>& r, CUstream_st* s) {
    return cuda_sum<F, false>(n, f, r, s);
  }
  template <class F>
  static std::uint64_t count(std::size_t n, const F& f, Reduction<std::uint64_t>& r, CUstream_st* s) {
    return cuda_sum<F, true>(n, f, r, s);
  }
};

}  // namespace ff
