#include "core/backend/host_buffer.h"

#include <cstdlib>
#include <utility>

#include "core/base/error.h"
#include "core/backend/host_wait.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include "core/backend/cuda/check.h"
#endif

namespace ff {

HostBuffer::~HostBuffer() { release(); }

HostBuffer::HostBuffer(HostBuffer&& o) noexcept
    : data_(o.data_), size_(o.size_), capacity_(o.capacity_), pinned_(o.pinned_) {
  o.data_ = nullptr;
  o.size_ = o.capacity_ = 0;
}

HostBuffer& HostBuffer::operator=(HostBuffer&& o) noexcept {
  if (this != &o) {
    release();
    data_ = o.data_;
    size_ = o.size_;
    capacity_ = o.capacity_;
    pinned_ = o.pinned_;
    o.data_ = nullptr;
    o.size_ = o.capacity_ = 0;
  }
  return *this;
}

void HostBuffer::release() {
  if (!data_) return;
#ifdef FLIPFLOW_HAVE_CUDA
  if (pinned_) {
    cudaFreeHost(data_);
    data_ = nullptr;
    return;
  }
#endif
  std::free(data_);
  data_ = nullptr;
}

void HostBuffer::resize(std::size_t bytes) {
  size_ = bytes;
  if (bytes <= capacity_) return;
  release();
  capacity_ = 0;
#ifdef FLIPFLOW_HAVE_CUDA
  if (pinned_) {
    void* p = nullptr;
    FF_CUDA_CHECK(cudaMallocHost(&p, bytes), "allocating pinned host memory for output");
    data_ = static_cast<unsigned char*>(p);
    capacity_ = bytes;
    return;
  }
#endif
  data_ = static_cast<unsigned char*>(std::malloc(bytes ? bytes : 1));
  if (!data_) throw RunError("out of host memory (" + std::to_string(bytes) + " bytes)");
  capacity_ = bytes;
}

StreamMark::~StreamMark() {
#ifdef FLIPFLOW_HAVE_CUDA
  if (event_) cudaEventDestroy(static_cast<cudaEvent_t>(event_));
#endif
}

StreamMark& StreamMark::operator=(StreamMark&& o) noexcept {
  std::swap(event_, o.event_);
  std::swap(recorded_, o.recorded_);
  return *this;
}

void StreamMark::record(CUstream_st* stream) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (!event_) {
    cudaEvent_t e;
    FF_CUDA_CHECK(cudaEventCreateWithFlags(&e, cudaEventDisableTiming), "creating an output event");
    event_ = e;
  }
  FF_CUDA_CHECK(cudaEventRecord(static_cast<cudaEvent_t>(event_), stream), "recording an output event");
  recorded_ = true;
#else
  (void)stream;
#endif
}

void StreamMark::wait() {
#ifdef FLIPFLOW_HAVE_CUDA
  if (event_ && recorded_) {
    const HostWait waiting;
    FF_CUDA_CHECK(cudaEventSynchronize(static_cast<cudaEvent_t>(event_)), "waiting for an output copy");
    recorded_ = false;
  }
#endif
}

void copy_device_to_host_async(void* host, const void* device, std::size_t bytes, CUstream_st* stream) {
#ifdef FLIPFLOW_HAVE_CUDA
  if (bytes)
    FF_CUDA_CHECK(cudaMemcpyAsync(host, device, bytes, cudaMemcpyDeviceToHost, stream), "copying output to the host");
#else
  (void)host, (void)device, (void)bytes, (void)stream;
  throw RunError("device copy in a build without CUDA");
#endif
}

}  // namespace ff
