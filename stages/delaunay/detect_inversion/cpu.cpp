#include "core/exec_cpu.h"
#include "stages/delaunay/detect_inversion/cpu.h"

namespace ff::delaunay {

template <class R>
DetectOps<R> detect_cpu_ops() {
  return {&cpu_for_each<MarkInversions<R>>, &cpu_for_each<CheckInverted<R>>, cpu_mem_ops()};
}
template DetectOps<float> detect_cpu_ops<float>();
template DetectOps<double> detect_cpu_ops<double>();

}  // namespace ff::delaunay
