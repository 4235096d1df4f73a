// The loops of pair.lj, declared for stage.h: the CPU's vector lanes (cpu.cpp) and the CUDA loops
// (cuda.cu), both summing kernel.h's functor terms in row order. nvcc-clean.
#pragma once
#include <cstddef>

#include "core/backend/exec.h"
#include "core/backend/memory.h"
#include "plugins/pair/lj/kernel.h"

namespace ff::pair {

// Memory the loops keep between steps.
template <class R>
struct LJScratch {
  template <class Exec>
  explicit LJScratch(Exec exec) : record(exec) {}
  Scratch<R> record;  // N x 4: each particle's position (D reals, then zeros) and diameter (CPU: double only)
};

template <class R>
struct LJLoops {
  // Rows [0, n) (a decomposed team's owned particles), reading any of the `held` particles.
  void (*d2)(std::size_t n, std::size_t held, const LJForce<R, 2>& f, LJScratch<R>& scratch,
             CUstream_st* stream) = nullptr;
  void (*d3)(std::size_t n, std::size_t held, const LJForce<R, 3>& f, LJScratch<R>& scratch,
             CUstream_st* stream) = nullptr;
};

template <class R>
LJLoops<R> lj_loops(CpuExec);
template <class R>
LJLoops<R> lj_loops(CudaExec);

}  // namespace ff::pair
