#include "core/overdamped_cpu.h"
#include "plugins/abp/integrate/cpu.h"

namespace ff::abp {

template <class R>
IntegrateLoops<R> cpu_loops() {
  return {&cpu_overdamped_for_each<AbpStep<R, 2>>, &cpu_overdamped_for_each<AbpStep<R, 3>>};
}
template IntegrateLoops<float> cpu_loops<float>();
template IntegrateLoops<double> cpu_loops<double>();

}  // namespace ff::abp
