#include "core/cuda/loop.cuh"
#include "stages/delaunay/flip/cuda.cuh"

namespace ff::delaunay {

template <class R>
FlipOps<R> flip_cuda_ops() {
  return {&cuda_for_each<DecideFlips>, &cuda_for_each<ApplyFlips>, &cuda_for_each<MarkInversions<R>>, cuda_mem_ops()};
}
template FlipOps<float> flip_cuda_ops<float>();
template FlipOps<double> flip_cuda_ops<double>();

}  // namespace ff::delaunay
