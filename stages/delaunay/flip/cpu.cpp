#include "core/backend/exec_cpu.h"
#include "stages/delaunay/flip/stage.h"

namespace ff::delaunay {

template <class R>
FlipOps<R> flip_ops(CpuExec) {
  return {&cpu_for_each<DecideFlips>, &cpu_for_each<ApplyFlips>, &cpu_for_each<MarkInversions<R>>, cpu_mem_ops()};
}
template FlipOps<float> flip_ops<float>(CpuExec);
template FlipOps<double> flip_ops<double>(CpuExec);

}  // namespace ff::delaunay
