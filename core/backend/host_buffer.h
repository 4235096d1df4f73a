// Host memory for staging device data: page-locked (pinned) when the CUDA backend is built,
// so device-to-host copies into it are truly asynchronous; plain memory otherwise.
#pragma once
#include <cstddef>

struct CUstream_st;

namespace ff {

class HostBuffer {
 public:
  HostBuffer() = default;
  explicit HostBuffer(bool pinned) : pinned_(pinned) {}
  ~HostBuffer();
  HostBuffer(HostBuffer&& o) noexcept;
  HostBuffer& operator=(HostBuffer&& o) noexcept;
  HostBuffer(const HostBuffer&) = delete;
  HostBuffer& operator=(const HostBuffer&) = delete;

  // Grows (never shrinks) the allocation; contents are not kept.
  void resize(std::size_t bytes);
  std::size_t size() const { return size_; }
  unsigned char* data() { return data_; }
  const unsigned char* data() const { return data_; }

 private:
  void release();
  unsigned char* data_ = nullptr;
  std::size_t size_ = 0, capacity_ = 0;
  bool pinned_ = false;
};

// A point in a CUDA stream that another thread can wait for (no-op without CUDA).
class StreamMark {
 public:
  StreamMark() = default;
  ~StreamMark();
  // A moved mark keeps its recorded point: a Frame moves through the writer's queue between
  // its record() and the writer thread's wait().
  StreamMark(StreamMark&& o) noexcept : event_(o.event_), recorded_(o.recorded_) {
    o.event_ = nullptr;
    o.recorded_ = false;
  }
  StreamMark& operator=(StreamMark&& o) noexcept;
  StreamMark(const StreamMark&) = delete;
  StreamMark& operator=(const StreamMark&) = delete;

  void record(CUstream_st* stream);  // mark the current end of `stream`
  void wait();                       // block this thread until the mark is reached
 private:
  void* event_ = nullptr;
  bool recorded_ = false;
};

// Asynchronous device-to-host copy on `stream` (throws in a build without CUDA).
void copy_device_to_host_async(void* host, const void* device, std::size_t bytes, CUstream_st* stream);

}  // namespace ff
