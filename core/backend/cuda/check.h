// FF_CUDA_CHECK(expr, "what we were doing"): throws ff::RunError with file, line, the CUDA error
// name and message. FF_CUDA_CHECK_LAUNCH("kernel") checks the last launch, and synchronizes
// first when built with FLIPFLOW_CUDA_SYNC_DEBUG so an asynchronous fault is blamed on the
// kernel that caused it. Usable from .cpp and .cu files alike.
#pragma once
#include <cuda_runtime.h>

#include <cstddef>
#include <string>

namespace ff::cuda_detail {
[[noreturn]] void throw_cuda_error(cudaError_t err, const char* expr, const char* what,
                                   const char* file, int line);
// For an allocation that failed with `err`: a RunError "out of GPU memory: BYTES bytes for
// WHAT; the device has FREE of TOTAL MiB free" (and what to do) when err is
// cudaErrorMemoryAllocation, else the plain CUDA error. `what` names the field or the array.
[[noreturn]] void throw_allocation_error(cudaError_t err, std::size_t bytes, const std::string& what,
                                         const char* file, int line);
}

// cudaMalloc(&ptr, bytes), or throw_allocation_error naming `what`.
#define FF_CUDA_ALLOC(ptr, bytes, what)                                                            \
  do {                                                                                             \
    cudaError_t ff_err_ = cudaMalloc(&(ptr), (bytes));                                             \
    if (ff_err_ != cudaSuccess) ::ff::cuda_detail::throw_allocation_error(ff_err_, (bytes), (what), __FILE__, __LINE__); \
  } while (0)

#define FF_CUDA_CHECK(expr, what)                                                   \
  do {                                                                              \
    cudaError_t ff_err_ = (expr);                                                   \
    if (ff_err_ != cudaSuccess)                                                     \
      ::ff::cuda_detail::throw_cuda_error(ff_err_, #expr, what, __FILE__, __LINE__); \
  } while (0)

#ifdef FLIPFLOW_CUDA_SYNC_DEBUG
#define FF_CUDA_CHECK_LAUNCH(what)                          \
  do {                                                      \
    FF_CUDA_CHECK(cudaGetLastError(), what);                \
    FF_CUDA_CHECK(cudaDeviceSynchronize(), what);           \
  } while (0)
#else
#define FF_CUDA_CHECK_LAUNCH(what) FF_CUDA_CHECK(cudaGetLastError(), what)
#endif
