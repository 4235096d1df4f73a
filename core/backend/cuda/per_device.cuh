// A value that belongs to the current CUDA device (an occupancy, whether a cluster fits), asked
// once per device and remembered. Process-wide caches of such values must be keyed by device:
// a rank of a team and a run of an in-process sweep each make another GPU current on their thread
// (use_cuda_device), and its model, or the attributes set on it, may differ. Include only from
// .cu files.
#pragma once
#include <cuda_runtime.h>

#include <atomic>

#include "core/backend/cuda/check.h"

namespace ff {

// `ask()` (a value >= 0) on the current device, asked the first time a device asks and then
// remembered in `known` (0: not asked; else the value + 1). Two threads asking at once for the
// same device both ask: `ask` must give the same value either way. Beyond 64 devices it always asks.
template <class Ask>
int once_per_device(std::atomic<int> (&known)[64], Ask ask) {
  int dev = 0;
  FF_CUDA_CHECK(cudaGetDevice(&dev), "the current device");
  if (dev < 0 || dev >= 64) return ask();
  int k = known[dev].load(std::memory_order_acquire);
  if (k == 0) {
    k = ask() + 1;
    known[dev].store(k, std::memory_order_release);
  }
  return k - 1;
}

}  // namespace ff
