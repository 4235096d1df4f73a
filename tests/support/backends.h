// One test body, every backend: GENERATE(from_range(ff::test::backends())) runs a section per
// available backend; CUDA is skipped with a visible WARN on a machine without a GPU.
#pragma once
#include <catch2/catch.hpp>
#include <vector>

#include "core/backend/device.h"

namespace ff::test {

inline std::vector<Backend> backends() {
  std::vector<Backend> b{Backend::cpu};
  if (cuda_device_available()) b.push_back(Backend::cuda);
  return b;
}

// For CPU-vs-CUDA comparisons: returns false (and warns visibly) when there is no GPU.
inline bool have_cuda(const char* what) {
  if (cuda_device_available()) return true;
  WARN("SKIPPED (" + no_cuda_device_reason() + "): " + what);
  return false;
}

}  // namespace ff::test
