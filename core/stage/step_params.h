// The per-step values a kernel may need: kernels read them only through StepContext::params, on
// the stage's side (core/stage/stage.h says why); StepContext::host_params holds them for host
// logic. nvcc-clean.
#pragma once
#include <cstdint>

namespace ff {

struct StepParams {
  std::uint64_t step;
  std::uint32_t attempt;
  double dt;
  double time;
};

}  // namespace ff
