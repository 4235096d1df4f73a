#include "core/cuda/loop.cuh"
#include "plugins/abp/integrate/cuda.cuh"

namespace ff::abp {

template <class R>
IntegrateLoops<R> cuda_loops() {
  return {&cuda_for_each<AbpStep<R, 2>>, &cuda_for_each<AbpStep<R, 3>>};
}
template IntegrateLoops<float> cuda_loops<float>();
template IntegrateLoops<double> cuda_loops<double>();

}  // namespace ff::abp
