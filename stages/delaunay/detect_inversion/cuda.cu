#include "core/cuda/loop.cuh"
#include "stages/delaunay/detect_inversion/cuda.cuh"

namespace ff::delaunay {

template <class R>
DetectOps<R> detect_cuda_ops() {
  return {&cuda_for_each<MarkInversions<R>>, &cuda_for_each<CheckInverted<R>>, cuda_mem_ops()};
}
template DetectOps<float> detect_cuda_ops<float>();
template DetectOps<double> detect_cuda_ops<double>();

}  // namespace ff::delaunay
