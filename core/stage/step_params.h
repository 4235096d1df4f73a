// The per-step values a kernel may need (see StepContext::params in core/stage/stage.h). nvcc-clean.
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
