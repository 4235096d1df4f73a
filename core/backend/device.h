// Which backends this process can use.
#pragma once
#include <string>

#include "core/base/types.h"

namespace ff {

bool built_with_cuda();
// True when built with CUDA and a CUDA device is usable now.
bool cuda_device_available();
// A line for logs about the current device: "NVIDIA H100 80GB HBM3 (sm_90, 132 SMs)", or why there
// is none.
std::string cuda_device_description();
// Why cuda_device_available() is false, beginning "no CUDA device" (the tests' SKIPPED lines).
std::string no_cuda_device_reason();
// CUDA devices visible to this process (0 without CUDA or a driver).
int cuda_device_count();
// Makes `device` the calling thread's current CUDA device (a rank's thread, core/run/team.h).
void use_cuda_device(int device);
// --device auto|cpu|cuda -> backend; InputError when cuda is asked for and unavailable.
Backend resolve_backend(const std::string& choice);

// How many runs share this process's GPU at once; 1 for a run alone. `pipeline sweep` says so:
// set_runs_sharing_gpu in its own process (--in-process), FLIPFLOW_RUNS_SHARING_GPU in its child
// processes' environment. A stage may size its device work by it, never its results:
// overlap_correct gives each run's correction fewer SMs when many runs share the GPU.
int runs_sharing_gpu();
void set_runs_sharing_gpu(int runs);

}  // namespace ff
