// Execution helpers: "physics once, loops twice". A stage's per-element operation is a functor
// with an FF_HD operator()(std::size_t i) in its kernel.h. cpu.cpp instantiates cpu_for_each
// (core/backend/exec_cpu.h, oneTBB), cuda.cu instantiates cuda_for_each (core/backend/cuda/loop.cuh); the
// stage holds a pointer to whichever loop matches its backend. nvcc-clean.
#pragma once
#include <cstddef>

#include "core/base/types.h"

namespace ff {

// The backends a stage template is built for (core/stage/stage_registration.h): CpuExec in
// core/backend/exec_cpu.h, CudaExec in core/backend/cuda/loop.cuh. Declared here so a stage.h can name the
// loops it writes by hand for each (`Loops loops(CpuExec)`, defined in its cpu.cpp / cuda.cu).
struct CpuExec;
struct CudaExec;

template <class F>
using ElementLoop = void (*)(std::size_t n, const F& f, CUstream_st* stream);

}  // namespace ff
