#include "core/backend/cuda/loop.cuh"
#include "stages/delaunay/detect_inversion/stage.h"

namespace ff::delaunay {

// MarkInversions at 6 blocks of 256 per SM (40 registers, no spills) instead of the default
// allocation's 48 registers and 5 blocks: one block more per SM, measured faster at 2^20
// (bench-abp on the H100, interleaved; 8 blocks spill and gain less; numbers in bench/README.md,
// "Numbers formerly in source comments").
constexpr int kMarkBlocks = 6;

template <class R>
DetectInversionLoops<R> detect_inversion_loops(CudaExec) {
  return {&CudaExec::for_each_bounded<MarkInversions<R>, kMarkBlocks>, &CudaExec::for_each<CheckInverted<R>>};
}
template DetectInversionLoops<float> detect_inversion_loops<float>(CudaExec);
template DetectInversionLoops<double> detect_inversion_loops<double>(CudaExec);

}  // namespace ff::delaunay
