// The CPU element loop (oneTBB). Include only from cpu.cpp files. Elementwise loops are
// deterministic for any thread count; reductions must use a fixed order (see DESIGN.md).
#pragma once
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/parallel_reduce.h>

#include <algorithm>
#include <cstdint>

#include "core/backend/exec.h"
#include "core/backend/field.h"
#include "core/backend/memory.h"
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

// max of f(i) over [0, n) (0 when n = 0), by oneTBB. Integer max: the same for any split.
template <class F>
std::uint32_t cpu_max(std::size_t n, const F& f) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 4096), std::uint32_t(0),
      [&](const tbb::blocked_range<std::size_t>& r, std::uint32_t m) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) m = std::max(m, std::uint32_t(f(i)));
        return m;
      },
      [](std::uint32_t a, std::uint32_t b) { return std::max(a, b); });
}

// Σ f(i) over [0, n) modulo 2^64, by oneTBB. Integer sums: the same for any split.
template <class F>
std::uint64_t cpu_sum(std::size_t n, const F& f) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 4096), std::uint64_t(0),
      [&](const tbb::blocked_range<std::size_t>& r, std::uint64_t m) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) m += std::uint64_t(f(i));
        return m;
      },
      [](std::uint64_t a, std::uint64_t b) { return a + b; });
}

// The CPU backend object a stage template's constructor receives (core/stage/stage_registration.h):
// element loops, reductions and the backend's memory (core/backend/memory.h). CudaExec
// (core/backend/cuda/loop.cuh) has the same members.
struct CpuExec {
  static constexpr Backend backend = Backend::cpu;
  static constexpr Where where = Where::host;
  // Scratch, counters and reduction words on this backend: Scratch<T> s{exec}.
  static const MemoryOps& memory() { return cpu_memory(); }
  template <class F>
  static void for_each(std::size_t n, const F& f, CUstream_st* s) { cpu_for_each(n, f, s); }
  // CudaExec::for_each_bounded caps a kernel's registers for occupancy; the CPU has nothing to
  // cap: the plain loop.
  template <class F, int MinBlocks>
  static void for_each_bounded(std::size_t n, const F& f, CUstream_st* s) { cpu_for_each(n, f, s); }
  // The overdamped integrators' loop (core/physics/overdamped.h): noise drawn 16 particles at a time.
  template <class F>
  static void overdamped(std::size_t n, const F& f, CUstream_st* s) { cpu_overdamped_for_each(n, f, s); }
  // Reductions over [0, n), returned to the host (the CUDA ones wait for the stream). All are
  // integer reductions, so the result does not depend on the order of the terms, the thread
  // count or the backend: max of f(i) (std::uint32_t), Σ f(i) (std::uint64_t, modulo 2^64) and
  // the count of i with f(i) true. There is no floating-point sum: a stage that needs one sums
  // its terms in fixed point (rounded to integers, as overlap_correct's counters are), which
  // keeps the result bit-identical across runs and backends. `r` is CUDA's result word.
  template <class F>
  static std::uint32_t max(std::size_t n, const F& f, Reduction<std::uint32_t>& /*r*/, CUstream_st* /*s*/) {
    return cpu_max(n, f);
  }
  template <class F>
  static std::uint64_t sum(std::size_t n, const F& f, Reduction<std::uint64_t>& /*r*/, CUstream_st* /*s*/) {
    return cpu_sum(n, f);
  }
  template <class F>
  static std::uint64_t count(std::size_t n, const F& f, Reduction<std::uint64_t>& /*r*/, CUstream_st* /*s*/) {
    return cpu_sum(n, [&](std::size_t i) { return f(i) ? 1u : 0u; });
  }
};

}  // namespace ff
