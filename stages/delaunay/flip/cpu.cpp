#include "core/exec_cpu.h"
#include "stages/delaunay/flip/cpu.h"

namespace ff::delaunay {

template <class R>
FlipOps<R> flip_cpu_ops() {
  return {&cpu_for_each<DecideFlips>, &cpu_for_each<ApplyFlips>, &cpu_for_each<MarkInversions<R>>, cpu_mem_ops()};
}
template FlipOps<float> flip_cpu_ops<float>();
template FlipOps<double> flip_cpu_ops<double>();

}  // namespace ff::delaunay
