// CPU loop of overlap_correct: every iteration gathers every particle and applies, with oneTBB
// element loops (core/exec_cpu.h) over the kernel.h functors.
#include <cstdlib>
#include <cstring>
#include <vector>

#include "core/exec_cpu.h"
#include "stages/overlap_correct/cpu.h"

namespace ff::overlap {

namespace {
struct HostWorkspace {
  std::vector<double> disp;  // N x 2
};

void* host_create(std::size_t n) {
  auto* w = new HostWorkspace;
  w->disp.resize(2 * n);
  return w;
}
void host_destroy(void* p) { delete static_cast<HostWorkspace*>(p); }

template <class R>
void host_iterate(void* ws, const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, Batch& out,
                  CUstream_st* s) {
  auto* w = static_cast<HostWorkspace*>(ws);
  const Gather<R> gather{p.mesh, w->disp.data(), nullptr};
  const Apply<R> apply{p.pos, p.image, w->disp.data(), p.box};
  out.gathers = 0;
  for (int j = 0; j < kBatch; ++j) {
    std::uint64_t* c = out.counters[j];
    std::memset(c, 0, kCounters * sizeof(std::uint64_t));
    Gather<R> g = gather;
    g.counters = c;
    cpu_for_each(p.n, g, s);
    out.gathers = j + 1;
    if (!keeps_going(c, k0 + j, max_iterations)) return;
    cpu_for_each(p.n, apply, s);
  }
}
}  // namespace

template <class R>
Ops<R> cpu_ops() {
  return {&host_create, &host_destroy, &host_iterate<R>};
}
template Ops<float> cpu_ops<float>();
template Ops<double> cpu_ops<double>();

}  // namespace ff::overlap
