#include <cuda_runtime.h>

#include <cstring>

#include "core/cuda/check.h"
#include "stages/delaunay/common/memory.h"

namespace ff::delaunay {

namespace {
void* dev_alloc(std::size_t bytes) {
  if (bytes == 0) return nullptr;
  void* p = nullptr;
  FF_CUDA_CHECK(cudaMalloc(&p, bytes), "allocating delaunay scratch memory");
  FF_CUDA_CHECK(cudaMemset(p, 0, bytes), "clearing delaunay scratch memory");
  return p;
}
void dev_release(void* p) {
  if (p) cudaFree(p);
}
void* pinned_alloc(std::size_t bytes) {
  if (bytes == 0) return nullptr;
  void* p = nullptr;
  FF_CUDA_CHECK(cudaMallocHost(&p, bytes), "allocating pinned delaunay counters");
  std::memset(p, 0, bytes);
  return p;
}
void pinned_release(void* p) {
  if (p) cudaFreeHost(p);
}
void dev_download(void* dst, const void* src, std::size_t bytes, CUstream_st* s) {
  if (!bytes) return;
  FF_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, s), "reading delaunay counters");
  FF_CUDA_CHECK(cudaStreamSynchronize(s), "waiting for delaunay counters");
}
void dev_copy(void* dst, const void* src, std::size_t bytes, CUstream_st* s) {
  if (bytes) FF_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToDevice, s), "copying a delaunay buffer");
}
void dev_fill(void* dst, int byte, std::size_t bytes, CUstream_st* s) {
  if (bytes) FF_CUDA_CHECK(cudaMemsetAsync(dst, byte, bytes, s), "resetting delaunay counters");
}
void dev_download_async(void* dst, const void* src, std::size_t bytes, CUstream_st* s) {
  if (bytes) FF_CUDA_CHECK(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, s), "reading delaunay counters");
}
void* event_create() {
  cudaEvent_t e = nullptr;
  FF_CUDA_CHECK(cudaEventCreateWithFlags(&e, cudaEventDisableTiming), "creating a delaunay counter fence");
  return e;
}
void event_destroy(void* e) {
  if (e) cudaEventDestroy(static_cast<cudaEvent_t>(e));
}
void event_record(void* e, CUstream_st* s) {
  FF_CUDA_CHECK(cudaEventRecord(static_cast<cudaEvent_t>(e), s), "recording a delaunay counter fence");
}
void event_wait(void* e) {
  FF_CUDA_CHECK(cudaEventSynchronize(static_cast<cudaEvent_t>(e)), "waiting for delaunay counters");
}
}  // namespace

MemOps cuda_mem_ops() {
  return {&dev_alloc, &dev_release,        &pinned_alloc, &pinned_release, &dev_download, &dev_copy,
          &dev_fill,  &dev_download_async, &event_create, &event_destroy,  &event_record, &event_wait};
}

}  // namespace ff::delaunay
