// The CPU element loop (oneTBB). Include only from cpu.cpp files. Elementwise loops are
// deterministic for any thread count; reductions must use a fixed order (see DESIGN.md).
#pragma once
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include "core/backend/exec.h"
#include "core/backend/field.h"
#include "core/backend/overdamped_cpu.h"

namespace ff {

// The element loop on the calling thread only (what cpu_for_each does for short loops).
// Element functors are inlined into the loops (flatten): called out of line (through the PLT,
// as a template in a shared library) and reloading the functor's members for every element,
// the edge loops were measurably slower (bench/README.md, numbers formerly in comments).
template <class F>
__attribute__((flatten)) void cpu_serial_for_each(std::size_t n, const F& f, CUstream_st* /*stream*/) {
  const F local = f;  // see cpu_for_each
  for (std::size_t i = 0; i < n; ++i) local(i);
}

// Loops of at most `grain` elements run on the calling thread.
template <class F, std::size_t grain = 2048>
void cpu_for_each(std::size_t n, const F& f, CUstream_st* /*stream*/) {
  if (n <= grain) {
    cpu_serial_for_each(n, f, nullptr);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const tbb::blocked_range<std::size_t>& r) __attribute__((flatten)) {
    // A private copy: the compiler may keep its members in registers across the loop's atomic
    // counter updates, which it must assume can change anything reachable through `f`.
    const F local = f;
    for (std::size_t i = r.begin(); i != r.end(); ++i) local(i);
  });
}

// The CPU backend of a stage template (core/stage/stage_registration.h): its element loops.
struct CpuExec {
  static constexpr Backend backend = Backend::cpu;
  static constexpr Where where = Where::host;
  template <class F>
  static void for_each(std::size_t n, const F& f, CUstream_st* s) { cpu_for_each(n, f, s); }
  // The overdamped integrators' loop (core/physics/overdamped.h): noise drawn 16 particles at a time.
  template <class F>
  static void overdamped(std::size_t n, const F& f, CUstream_st* s) { cpu_overdamped_for_each(n, f, s); }
};

}  // namespace ff
