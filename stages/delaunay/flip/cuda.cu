#include "core/backend/cuda/loop.cuh"
#include "stages/delaunay/flip/stage.h"

namespace ff::delaunay {

template <class R>
FlipOps<R> flip_ops(CudaExec) {
  return {&cuda_for_each<DecideFlips>, &cuda_for_each<ApplyFlips>, &cuda_for_each<MarkInversions<R>>, cuda_mem_ops()};
}
template FlipOps<float> flip_ops<float>(CudaExec);
template FlipOps<double> flip_ops<double>(CudaExec);

}  // namespace ff::delaunay
