#include "core/backend/cuda/device_buffer.h"

#include "core/backend/cuda/check.h"
#include "core/backend/host_wait.h"
#include "core/base/error.h"

namespace ff {

namespace cuda_detail {
void throw_cuda_error(cudaError_t err, const char* expr, const char* what, const char* file,
                      int line) {
  throw RunError(std::string("CUDA error ") + cudaGetErrorName(err) + " (" +
                 cudaGetErrorString(err) + ") while " + what + " [" + expr + "] at " + file +
                 ":" + std::to_string(line));
}
void throw_allocation_error(cudaError_t err, std::size_t bytes, const std::string& what, const char* file,
                            int line) {
  if (err != cudaErrorMemoryAllocation)
    throw_cuda_error(err, "cudaMalloc", ("allocating " + what).c_str(), file, line);
  cudaGetLastError();  // not sticky: clear it, so the run can end cleanly (finish, output)
  std::size_t free = 0, total = 0;
  std::string device;
  if (cudaMemGetInfo(&free, &total) == cudaSuccess)
    device = "; the device has " + std::to_string(free >> 20) + " MiB free of " + std::to_string(total >> 20) +
             " MiB";
  throw RunError("out of GPU memory: " + std::to_string(bytes) + " bytes (" + std::to_string(bytes >> 20) +
                 " MiB) for " + what + device +
                 " (other processes on the GPU count too); lower system.N, or run with --device cpu");
}
}  // namespace cuda_detail

DeviceBuffer::DeviceBuffer(std::size_t bytes, const std::string& what) : bytes_(bytes) {
  if (bytes) FF_CUDA_ALLOC(ptr_, bytes, what);
}

DeviceBuffer::~DeviceBuffer() {
  if (ptr_) cudaFree(ptr_);
}

// A null stream means "from outside the step" (tests, set-up, output after the run): the
// flipflow streams are non-blocking and do not order with the legacy default stream, so such
// an access must wait for all device work first.
void DeviceBuffer::upload(const void* host, std::size_t bytes, CUstream_st* stream) {
  if (!bytes) return;
  const HostWait waiting;  // (a blocking copy: the host does nothing else meanwhile)
  if (!stream) {
    FF_CUDA_CHECK(cudaDeviceSynchronize(), "waiting for the device before a field copy");
    FF_CUDA_CHECK(cudaMemcpy(ptr_, host, bytes, cudaMemcpyHostToDevice), "copying a field to the device");
    // From pageable memory cudaMemcpy may return once the data is staged, before it lands: wait,
    // so that work queued next on a non-blocking stream reads the new values.
    FF_CUDA_CHECK(cudaDeviceSynchronize(), "copying a field to the device");
    return;
  }
  FF_CUDA_CHECK(cudaMemcpyAsync(ptr_, host, bytes, cudaMemcpyHostToDevice, stream),
                "copying a field to the device");
  // Wait for it to land: the field is valid on the device from here on, and a stage on another
  // stream that reads it too (two unordered readers) would not be ordered after this copy.
  // Uploads follow host writes only (the first step, a resume, a host stage), never a captured step.
  FF_CUDA_CHECK(cudaStreamSynchronize(stream), "copying a field to the device");
}

void DeviceBuffer::download(void* host, std::size_t bytes, CUstream_st* stream) {
  if (!bytes) return;
  const HostWait waiting;
  if (!stream) {
    FF_CUDA_CHECK(cudaDeviceSynchronize(), "waiting for the device before a field copy");
    FF_CUDA_CHECK(cudaMemcpy(host, ptr_, bytes, cudaMemcpyDeviceToHost), "copying a field to the host");
    return;
  }
  FF_CUDA_CHECK(cudaMemcpyAsync(host, ptr_, bytes, cudaMemcpyDeviceToHost, stream),
                "copying a field to the host");
  FF_CUDA_CHECK(cudaStreamSynchronize(stream), "waiting for a field copy to the host");
}

}  // namespace ff
