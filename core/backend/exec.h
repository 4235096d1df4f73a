// Execution helpers: "physics once, loops twice". A stage's per-element operation is a functor
// with an FF_HD operator()(std::size_t i) in its kernel.h. The backend object its constructor
// receives (CpuExec: core/backend/exec_cpu.h, oneTBB; CudaExec: core/backend/cuda/loop.cuh)
// instantiates the loops and reductions over it (Exec::for_each, Exec::max, ...); the stage
// holds pointers to them, and reaches the backend's memory (Scratch, Counters: memory.h) through
// Exec::memory(). nvcc-clean.
#pragma once
#include <cstddef>

#include "core/backend/memory.h"
#include "core/base/types.h"

namespace ff {

// The backends a stage template is built for (core/stage/stage_registration.h): CpuExec in
// core/backend/exec_cpu.h, CudaExec in core/backend/cuda/loop.cuh. Declared here so a stage.h can name the
// loops it writes by hand for each (`<Stage>Loops <stage>_loops(CpuExec)`, defined in its
// cpu.cpp / cuda.cu).
struct CpuExec;
struct CudaExec;

template <class F>
using ElementLoop = void (*)(std::size_t n, const F& f, CUstream_st* stream);

// A reduction of the backend object (Exec::max, Exec::sum, Exec::count) over a functor F,
// returning T; `r` holds CUDA's result word across calls.
template <class F, class T>
using ReduceLoop = T (*)(std::size_t n, const F& f, Reduction<T>& r, CUstream_st* stream);

}  // namespace ff
