#include "core/backend/device.h"

#include <algorithm>
#include <atomic>
#include <cstdlib>

#include "core/base/error.h"
#ifdef FLIPFLOW_HAVE_CUDA
#include <cuda_runtime.h>
#endif

namespace ff {

bool built_with_cuda() {
#ifdef FLIPFLOW_HAVE_CUDA
  return true;
#else
  return false;
#endif
}

bool cuda_device_available() {
#ifdef FLIPFLOW_HAVE_CUDA
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    cudaGetLastError();  // clear the sticky "no driver" error
    return false;
  }
  return n > 0;
#else
  return false;
#endif
}

std::string cuda_device_description() {
#ifdef FLIPFLOW_HAVE_CUDA
  int n = 0;
  cudaError_t err = cudaGetDeviceCount(&n);
  if (err != cudaSuccess) return std::string("no CUDA device (") + cudaGetErrorString(err) + ")";
  if (n == 0) return "no CUDA device";
  int current = 0;  // the calling thread's: a rank's or a sweep's run on another GPU than 0
  if (cudaGetDevice(&current) != cudaSuccess) current = 0;
  cudaDeviceProp p{};
  cudaGetDeviceProperties(&p, current);
  return std::string(p.name) + " (sm_" + std::to_string(p.major) + std::to_string(p.minor) + ", " +
         std::to_string(p.multiProcessorCount) + " SMs)";
#else
  return "built without CUDA";
#endif
}

std::string no_cuda_device_reason() {
  const std::string d = cuda_device_description();
  return d.rfind("no CUDA device", 0) == 0 ? d : "no CUDA device: " + d;
}

int cuda_device_count() {
#ifdef FLIPFLOW_HAVE_CUDA
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return n;
#else
  return 0;
#endif
}

void use_cuda_device(int device) {
#ifdef FLIPFLOW_HAVE_CUDA
  const cudaError_t e = cudaSetDevice(device);
  if (e != cudaSuccess)
    throw RunError("cannot use CUDA device " + std::to_string(device) + ": " + cudaGetErrorString(e));
#else
  throw RunError("CUDA device " + std::to_string(device) + " asked for in a build without CUDA");
#endif
}

Backend resolve_backend(const std::string& choice) {
  if (choice == "cpu") return Backend::cpu;
  if (choice == "cuda") {
    if (!built_with_cuda())
      throw InputError("--device cuda: this flipflow was built without CUDA (nvcc was not found at configure time)");
    if (!cuda_device_available())
      throw InputError("--device cuda: " + cuda_device_description());
    return Backend::cuda;
  }
  if (choice == "auto") return cuda_device_available() ? Backend::cuda : Backend::cpu;
  throw InputError("--device must be auto, cpu or cuda (got '" + choice + "')");
}

namespace {
std::atomic<int> g_runs_sharing_gpu{0};  // 0: not known yet (the environment decides)
}  // namespace

int runs_sharing_gpu() {
  int k = g_runs_sharing_gpu.load();
  if (k > 0) return k;
  const char* env = std::getenv("FLIPFLOW_RUNS_SHARING_GPU");
  k = env ? std::max(1, std::atoi(env)) : 1;
  g_runs_sharing_gpu.store(k);
  return k;
}

void set_runs_sharing_gpu(int runs) { g_runs_sharing_gpu.store(std::max(1, runs)); }

}  // namespace ff
