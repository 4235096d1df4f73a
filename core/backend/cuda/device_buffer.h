// RAII device allocation plus the two stream-ordered copies a Field needs.
#pragma once
#include <cstddef>

struct CUstream_st;

namespace ff {

class DeviceBuffer {
 public:
  explicit DeviceBuffer(std::size_t bytes);
  ~DeviceBuffer();
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;

  void* data() { return ptr_; }
  std::size_t bytes() const { return bytes_; }
  // Copies complete in stream order; download synchronizes `stream` so the host may read.
  void upload(const void* host, std::size_t bytes, CUstream_st* stream);
  void download(void* host, std::size_t bytes, CUstream_st* stream);

 private:
  void* ptr_ = nullptr;
  std::size_t bytes_ = 0;
};

}  // namespace ff
