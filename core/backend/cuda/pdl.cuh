// Programmatic dependent launch (sm_90): a kernel launched with launch_after_previous may be
// scheduled before the kernel before it on the stream has finished; it calls
// wait_for_previous_kernel() before touching anything that kernel writes. A kernel that calls
// allow_next_kernel() lets the next such launch be scheduled from then on. Experiment (branch pdl).
#pragma once
#include <cuda_runtime.h>

#include "core/backend/cuda/check.h"

namespace ff {

__device__ __forceinline__ void wait_for_previous_kernel() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  asm volatile("griddepcontrol.wait;" ::: "memory");
#endif
}

__device__ __forceinline__ void allow_next_kernel() {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  asm volatile("griddepcontrol.launch_dependents;" ::: "memory");
#endif
}

// Adds the programmatic-serialization attribute to `attrs` at `count` (returns the new count).
inline unsigned programmatic_attr(cudaLaunchAttribute* attrs, unsigned count) {
  attrs[count].id = cudaLaunchAttributeProgrammaticStreamSerialization;
  attrs[count].val.programmaticStreamSerializationAllowed = 1;
  return count + 1;
}

template <class... Params, class... Args>
void launch_after_previous(void (*kernel)(Params...), dim3 grid, dim3 block, CUstream_st* stream, Args... args) {
  cudaLaunchConfig_t cfg = {};
  cfg.gridDim = grid;
  cfg.blockDim = block;
  cfg.stream = stream;
  cudaLaunchAttribute attr[1];
  cfg.numAttrs = programmatic_attr(attr, 0);
  cfg.attrs = attr;
  FF_CUDA_CHECK(cudaLaunchKernelEx(&cfg, kernel, args...), "a programmatic dependent launch");
}

}  // namespace ff
