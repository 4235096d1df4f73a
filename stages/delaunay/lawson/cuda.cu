#include "core/cuda/loop.cuh"
#include "stages/delaunay/lawson/cuda.cuh"

namespace ff::delaunay {

template <class R>
LawsonOps<R> lawson_cuda_ops() {
  return {&cuda_for_each<MarkNonDelaunay<R>>, &cuda_for_each<DecideMarked>, &cuda_for_each<ApplyMarked>, cuda_mem_ops()};
}
template LawsonOps<float> lawson_cuda_ops<float>();
template LawsonOps<double> lawson_cuda_ops<double>();

}  // namespace ff::delaunay
