#include "core/cuda/loop.cuh"
#include "plugins/phoretic/integrate/cuda.cuh"

namespace ff::phoretic {

template <class R>
IntegrateLoops<R> cuda_integrate_loops() {
  return {&cuda_for_each<PhoreticStep<R, 2>>, &cuda_for_each<PhoreticStep<R, 3>>};
}
template IntegrateLoops<float> cuda_integrate_loops<float>();
template IntegrateLoops<double> cuda_integrate_loops<double>();

}  // namespace ff::phoretic
