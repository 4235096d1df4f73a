// Which backends this process can use.
#pragma once
#include <string>

#include "core/base/types.h"

namespace ff {

bool built_with_cuda();
// True when built with CUDA and a CUDA device is usable now.
bool cuda_device_available();
// A line for logs: "NVIDIA H100 80GB HBM3 (sm_90, 132 SMs)" or why there is none.
std::string cuda_device_description();
// CUDA devices visible to this process (0 without CUDA or a driver).
int cuda_device_count();
// Makes `device` the calling thread's current CUDA device (a rank's thread, core/run/team.h).
void use_cuda_device(int device);
// --device auto|cpu|cuda -> backend; InputError when cuda is asked for and unavailable.
Backend resolve_backend(const std::string& choice);

}  // namespace ff
