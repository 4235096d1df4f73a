#include "core/exec_cpu.h"
#include "stages/delaunay/lawson/cpu.h"

namespace ff::delaunay {

// Lists are short (a few thousand edges per step at N = 2^16) and their elements append to
// shared lists: marking runs on one thread up to 16384 edges (most of what it tests is marked
// in round 0, detect_inversion's candidates), deciding and applying always (nearly every
// element bumps the flip count or the next round's list).
template <class R>
LawsonOps<R> lawson_cpu_ops() {
  return {&cpu_for_each<MarkNonDelaunay<R>, 16384>, &cpu_serial_for_each<DecideMarked>,
          &cpu_serial_for_each<ApplyMarked>, cpu_mem_ops()};
}
template LawsonOps<float> lawson_cpu_ops<float>();
template LawsonOps<double> lawson_cpu_ops<double>();

}  // namespace ff::delaunay
