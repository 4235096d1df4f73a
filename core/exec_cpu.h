// The CPU element loop (oneTBB). Include only from cpu.cpp files. Elementwise loops are
// deterministic for any thread count; reductions must use a fixed order (see DESIGN.md).
#pragma once
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include "core/exec.h"

namespace ff {

template <class F>
void cpu_for_each(std::size_t n, const F& f, CUstream_st* /*stream*/) {
  constexpr std::size_t grain = 2048;
  if (n <= grain) {
    for (std::size_t i = 0; i < n; ++i) f(i);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
  });
}

}  // namespace ff
