#include "core/overdamped_cpu.h"
#include "plugins/phoretic/integrate/cpu.h"

namespace ff::phoretic {

template <class R>
IntegrateLoops<R> cpu_integrate_loops() {
  return {&cpu_overdamped_for_each<PhoreticStep<R, 2>>, &cpu_overdamped_for_each<PhoreticStep<R, 3>>};
}
template IntegrateLoops<float> cpu_integrate_loops<float>();
template IntegrateLoops<double> cpu_integrate_loops<double>();

}  // namespace ff::phoretic
