// RAII device allocation plus the two stream-ordered copies a Field needs.
#pragma once
#include <cstddef>
#include <string>

struct CUstream_st;

namespace ff {

class DeviceBuffer {
 public:
  // `what` names the allocation in an out-of-memory error ("field 'position' (N = ...)").
  DeviceBuffer(std::size_t bytes, const std::string& what);
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
