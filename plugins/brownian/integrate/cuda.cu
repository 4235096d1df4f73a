#include "core/cuda/loop.cuh"
#include "plugins/brownian/integrate/cuda.cuh"

namespace ff::brownian {

template <class R>
IntegrateLoops<R> cuda_loops() {
  return {&cuda_for_each<BrownianStep<R, 2>>, &cuda_for_each<BrownianStep<R, 3>>};
}
template IntegrateLoops<float> cuda_loops<float>();
template IntegrateLoops<double> cuda_loops<double>();

}  // namespace ff::brownian
