#include "core/overdamped_cpu.h"
#include "plugins/brownian/integrate/cpu.h"

namespace ff::brownian {

template <class R>
IntegrateLoops<R> cpu_loops() {
  return {&cpu_overdamped_for_each<BrownianStep<R, 2>>, &cpu_overdamped_for_each<BrownianStep<R, 3>>};
}
template IntegrateLoops<float> cpu_loops<float>();
template IntegrateLoops<double> cpu_loops<double>();

}  // namespace ff::brownian
