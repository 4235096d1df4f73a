// One test body, every backend: GENERATE(from_range(ff::test::backends())) runs a section per
// available backend; CUDA is skipped with a visible WARN on a machine without a GPU.
#pragma once
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "core/backend/device.h"

namespace ff::test {

// A test of plugins built for the CPU only (FLIPFLOW_PLUGIN_CUDA=OFF against an install that has
// CUDA: flipflow_add_plugin defines FLIPFLOW_STAGE_TEST_CPU_ONLY) drives the CPU alone, GPU or not.
inline std::vector<Backend> backends() {
  std::vector<Backend> b{Backend::cpu};
#ifndef FLIPFLOW_STAGE_TEST_CPU_ONLY
  if (cuda_device_available()) b.push_back(Backend::cuda);
#endif
  return b;
}

// For CPU-vs-CUDA comparisons: returns false (and warns visibly) when there is no GPU, or no
// CUDA build of the plugins under test.
inline bool have_cuda(const char* what) {
#ifdef FLIPFLOW_STAGE_TEST_CPU_ONLY
  WARN(std::string("SKIPPED (plugins built with FLIPFLOW_PLUGIN_CUDA=OFF): ") + what);
  return false;
#else
  if (cuda_device_available()) return true;
  WARN("SKIPPED (" + no_cuda_device_reason() + "): " + what);
  return false;
#endif
}

}  // namespace ff::test
