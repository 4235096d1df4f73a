// Programmatic dependent launch (sm_90): a kernel launched with launch_after_previous (or with
// programmatic_attr among its launch attributes) may be scheduled before the kernel before it
// on the stream has finished, and calls wait_for_previous_kernel() before it touches anything:
// that returns once the previous kernel has ended and its writes are visible, so the results
// are those of an ordinary launch. A kernel that calls allow_next_kernel() (once every block
// has) lets the next such launch be scheduled while it runs. In a step of short kernels each
// one queued behind the last (bench-abp at small N with device decisions) this removes the gap
// between a kernel's end and the next one's start. On a device before sm_90 the launch is an
// ordinary one and both calls are empty.
#pragma once
#include <cuda_runtime.h>

#include <atomic>

#include "core/backend/cuda/check.h"
#include "core/backend/device.h"

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

// Whether the current device has programmatic dependent launches (sm_90 and later); asked once
// per device.
inline bool programmatic_launches() {
  static std::atomic<int> known[64] = {};  // per device: 0 not asked yet, 1 no, 2 yes
  int device = 0;
  FF_CUDA_CHECK(cudaGetDevice(&device), "the current device");
  if (device < 0 || device >= 64) return false;
  int k = known[device].load(std::memory_order_relaxed);
  if (k == 0) {
    int major = 0;
    FF_CUDA_CHECK(cudaDeviceGetAttribute(&major, cudaDevAttrComputeCapabilityMajor, device), "its compute capability");
    k = major >= 9 ? 2 : 1;
    known[device].store(k, std::memory_order_relaxed);
  }
  return k == 2;
}

// Adds the programmatic-serialization attribute to `attrs` at `count` where the device has it
// and the run has the GPU to itself; returns the new count. When runs share the GPU (`pipeline
// sweep`, runs_sharing_gpu) a kernel scheduled early holds its SMs while it waits (a correction
// cluster's block takes a whole SM's registers), SMs another run's kernels could use (a sweep
// with it on in every run was slower: bench/README.md, "Session 23").
inline unsigned programmatic_attr(cudaLaunchAttribute* attrs, unsigned count) {
  if (runs_sharing_gpu() > 1 || !programmatic_launches()) return count;
  attrs[count].id = cudaLaunchAttributeProgrammaticStreamSerialization;
  attrs[count].val.programmaticStreamSerializationAllowed = 1;
  return count + 1;
}

// Launches `kernel` so (programmatic_attr); `what` names it in the error of a failed launch.
template <class... Params, class... Args>
void launch_after_previous(const char* what, void (*kernel)(Params...), dim3 grid, dim3 block, CUstream_st* stream,
                           Args... args) {
  cudaLaunchConfig_t cfg = {};
  cfg.gridDim = grid;
  cfg.blockDim = block;
  cfg.stream = stream;
  cudaLaunchAttribute attr[1];
  cfg.numAttrs = programmatic_attr(attr, 0);
  cfg.attrs = attr;
  FF_CUDA_CHECK(cudaLaunchKernelEx(&cfg, kernel, args...), what);
  FF_CUDA_CHECK_LAUNCH(what);  // (with FLIPFLOW_CUDA_SYNC_DEBUG: waits, to blame a fault on this kernel)
}

}  // namespace ff
