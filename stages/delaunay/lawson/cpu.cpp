#include "core/exec_cpu.h"
#include "stages/delaunay/lawson/cpu.h"

namespace ff::delaunay {

template <class R>
LawsonOps<R> lawson_cpu_ops() {
  return {&cpu_for_each<MarkNonDelaunay<R>>, &cpu_for_each<DecideMarked>, &cpu_for_each<ApplyMarked>, cpu_mem_ops()};
}
template LawsonOps<float> lawson_cpu_ops<float>();
template LawsonOps<double> lawson_cpu_ops<double>();

}  // namespace ff::delaunay
