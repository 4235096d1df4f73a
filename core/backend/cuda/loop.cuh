// The CUDA element loop. Include only from .cu files. Launches on the stream the core gave the
// stage (never the default stream) and checks the launch (FF_CUDA_CHECK_LAUNCH).
#pragma once
#include <cuda_runtime.h>

#include "core/backend/cuda/check.h"
#include "core/backend/exec.h"
#include "core/backend/field.h"

namespace ff {

template <class F>
__global__ void for_each_kernel(std::size_t n, F f) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

template <class F>
void cuda_for_each(std::size_t n, const F& f, CUstream_st* stream) {
  if (n == 0) return;
  constexpr int block = 256;
  const unsigned grid = unsigned((n + block - 1) / block);
  for_each_kernel<F><<<grid, block, 0, stream>>>(n, f);
  FF_CUDA_CHECK_LAUNCH("launching an element loop");
}

// cuda_for_each with __launch_bounds__(256, MinBlocks): registers capped so that MinBlocks
// blocks fit on an SM. For a memory-bound loop whose occupancy the default allocation limits
// (measure first: a cap that forces spills usually loses).
template <class F, int MinBlocks>
__global__ void __launch_bounds__(256, MinBlocks) for_each_bounded_kernel(std::size_t n, F f) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

template <class F, int MinBlocks>
void cuda_for_each_bounded(std::size_t n, const F& f, CUstream_st* stream) {
  if (n == 0) return;
  constexpr int block = 256;
  const unsigned grid = unsigned((n + block - 1) / block);
  for_each_bounded_kernel<F, MinBlocks><<<grid, block, 0, stream>>>(n, f);
  FF_CUDA_CHECK_LAUNCH("launching an element loop");
}

// The CUDA backend of a stage template (core/stage/stage_registration.h): its element loops.
struct CudaExec {
  static constexpr Backend backend = Backend::cuda;
  static constexpr Where where = Where::device;
  template <class F>
  static void for_each(std::size_t n, const F& f, CUstream_st* s) { cuda_for_each(n, f, s); }
  // The overdamped integrators (core/physics/overdamped.h): one particle per thread (F::operator()).
  template <class F>
  static void overdamped(std::size_t n, const F& f, CUstream_st* s) { cuda_for_each(n, f, s); }
};

}  // namespace ff
