// The CUDA backend's memory (core/backend/memory.h): device memory, pinned host memory for
// counters, events as fences.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdint>
#include <cstring>

#include "core/backend/cuda/check.h"
#include "core/backend/host_wait.h"
#include "core/backend/memory.h"

namespace ff {

namespace {
// Copies by kernels instead of the copy engine: on the H100 a copy-engine copy after a kernel
// waits longer to start, and delays the next kernel more, than a kernel after a kernel does
// (CUPTI timeline of bench-abp; bench/overlap_correct-PERF.md, session 8). These sit on the
// step's critical path: detect_inversion's counter read and its position_prev copy.
__global__ void copy_words(unsigned* dst, const unsigned* src, std::size_t n) {
  for (std::size_t i = threadIdx.x; i < n; i += blockDim.x) dst[i] = src[i];
}
__global__ void copy_vec4(uint4* dst, const uint4* src, std::size_t n) {
  for (std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x; i < n; i += std::size_t(gridDim.x) * blockDim.x)
    dst[i] = __ldcs(src + i);  // streamed: read once
}

void* dev_alloc(std::size_t bytes) {
  if (bytes == 0) return nullptr;
  void* p = nullptr;
  FF_CUDA_ALLOC(p, bytes, std::string("a stage's scratch array (Scratch)"));
  // Zeroed before any step stream can touch it: the flipflow streams are non-blocking, so a
  // fill or kernel queued next on one of them could otherwise run first and have its values
  // zeroed under it (it happened with cudaMemset on the legacy stream and no wait, on a GPU
  // shared with other processes: detect_inversion's minimum slots, set to ~0u by reset(),
  // cleared to 0 afterwards). The clear runs on this thread's own default stream and the wait
  // is for that stream alone: a device-wide wait (cudaDeviceSynchronize) would also wait for
  // every other run's queued steps when runs share the process (`pipeline sweep --in-process`),
  // once per scratch array of every run's set-up.
  FF_CUDA_CHECK(cudaMemsetAsync(p, 0, bytes, cudaStreamPerThread), "clearing stage scratch memory");
  const HostWait waiting;
  FF_CUDA_CHECK(cudaStreamSynchronize(cudaStreamPerThread), "clearing stage scratch memory");
  return p;
}
void dev_release(void* p) {
  if (p) cudaFree(p);
}
void* pinned_alloc(std::size_t bytes) {
  if (bytes == 0) return nullptr;
  void* p = nullptr;
  FF_CUDA_CHECK(cudaMallocHost(&p, bytes), "allocating pinned host memory for stage counters");
  std::memset(p, 0, bytes);
  return p;
}
void pinned_release(void* p) {
  if (p) cudaFreeHost(p);
}
void dev_download(void* dst, const void* src, std::size_t bytes, CUstream_st* s) {
  if (!bytes) return;
  FF_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, s), "reading stage counters");
  const HostWait waiting;
  FF_CUDA_CHECK(cudaStreamSynchronize(s), "waiting for stage counters");
}
void dev_copy(void* dst, const void* src, std::size_t bytes, CUstream_st* s) {
  if (!bytes) return;
  const bool vec = bytes % 16 == 0 && reinterpret_cast<std::uintptr_t>(dst) % 16 == 0 &&
                   reinterpret_cast<std::uintptr_t>(src) % 16 == 0;
  if (!vec) {
    FF_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToDevice, s), "copying a stage buffer");
    return;
  }
  const std::size_t n = bytes / 16;
  constexpr unsigned kBlock = 256;
  const unsigned grid = unsigned(std::min<std::size_t>((n + kBlock - 1) / kBlock, 4096));
  copy_vec4<<<grid, kBlock, 0, s>>>(static_cast<uint4*>(dst), static_cast<const uint4*>(src), n);
  FF_CUDA_CHECK_LAUNCH("copying a stage buffer");
}
void dev_fill(void* dst, int byte, std::size_t bytes, CUstream_st* s) {
  if (bytes) FF_CUDA_CHECK(cudaMemsetAsync(dst, byte, bytes, s), "resetting stage counters");
}
// dst is pinned (alloc_host), which a kernel writes directly (unified addressing).
void dev_download_async(void* dst, const void* src, std::size_t bytes, CUstream_st* s) {
  if (!bytes) return;
  if (bytes % 4 != 0) {
    FF_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, s), "reading stage counters");
    return;
  }
  copy_words<<<1, 32, 0, s>>>(static_cast<unsigned*>(dst), static_cast<const unsigned*>(src), bytes / 4);
  FF_CUDA_CHECK_LAUNCH("reading stage counters");
}
// A fence the host waits on (Counters::finish_read, a few times a step). An event without
// cudaEventBlockingSync is waited for by spinning, whatever the device's scheduling flag: when the
// device blocks instead (`pipeline sweep --in-process` with more runs than cores, cmd_sweep.cpp),
// so does this wait: many runs spinning on fewer cores keep the cores from the runs that have work
// to launch (measured: bench/README.md, "Sweeps on one GPU"). A run alone keeps the spin: the
// wake-up of a blocked thread is latency on its step.
void* event_create() {
  unsigned flags = cudaEventDisableTiming;
  unsigned device_flags = 0;
  if (cudaGetDeviceFlags(&device_flags) == cudaSuccess &&
      (device_flags & cudaDeviceScheduleMask) == cudaDeviceScheduleBlockingSync)
    flags |= cudaEventBlockingSync;
  cudaEvent_t e = nullptr;
  FF_CUDA_CHECK(cudaEventCreateWithFlags(&e, flags), "creating a stage counter fence");
  return e;
}
void event_destroy(void* e) {
  if (e) cudaEventDestroy(static_cast<cudaEvent_t>(e));
}
void event_record(void* e, CUstream_st* s) {
  FF_CUDA_CHECK(cudaEventRecord(static_cast<cudaEvent_t>(e), s), "recording a stage counter fence");
}
void event_wait(void* e) {
  const HostWait waiting;
  FF_CUDA_CHECK(cudaEventSynchronize(static_cast<cudaEvent_t>(e)), "waiting for stage counters");
}
}  // namespace

const MemoryOps& cuda_memory() {
  static const MemoryOps ops{&dev_alloc,    &dev_release,        &pinned_alloc, &pinned_release,
                             &dev_download, &dev_copy,           &dev_fill,     &dev_download_async,
                             &event_create, &event_destroy,      &event_record, &event_wait};
  return ops;
}

}  // namespace ff
