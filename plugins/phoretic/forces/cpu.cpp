// CPU loops of phoretic.forces. Long range: a blocked all-pairs loop over the call's targets
// (all, or a rank's share). A block of 64 targets
// (one oneTBB task) keeps its coordinates and accumulators in small arrays; the sources stream
// past once per block, and each source updates the 64 independent accumulators, so the loop
// is throughput- rather than latency-bound and vectorizes over targets. Each target still adds
// its sources in ascending order, exactly as LongRangeVelocity::operator() does.
// Short range: the element loop over Verlet rows.
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <vector>

#include "core/backend/exec_cpu.h"
#include "plugins/phoretic/forces/stage.h"

namespace ff::phoretic {

namespace {

template <class R, int D>
void cpu_long_range(const LongRangeVelocity<R, D>& f, CUstream_st* /*stream*/) {
  constexpr std::size_t kTargets = 64;
  const std::size_t n = f.n, first = f.first_target, end = f.end_target();
  if (end <= first) return;
  std::vector<R> alpha(n);
  for (std::size_t k = 0; k < n; ++k) alpha[k] = f.alpha_of(k);
  const std::size_t blocks = (end - first + kTargets - 1) / kTargets;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t b = r.begin(); b != r.end(); ++b) {
      const std::size_t i0 = first + b * kTargets, m = std::min(end, i0 + kTargets) - i0;
      R xt[D][kTargets] = {}, acc[D][kTargets] = {};
      for (std::size_t t = 0; t < m; ++t)
        for (int c = 0; c < D; ++c) xt[c][t] = f.position[(i0 + t) * D + c];
      for (std::size_t k = 0; k < n; ++k) {
        R xk[D];
        for (int c = 0; c < D; ++c) xk[c] = f.position[k * D + c];
        const R ak = alpha[k];
        for (std::size_t t = 0; t < kTargets; ++t) {  // full block: padding targets are discarded
          R xi[D], a[D];
          for (int c = 0; c < D; ++c) {
            xi[c] = xt[c][t];
            a[c] = acc[c][t];
          }
          f.add(a, xi, xk, ak);
          for (int c = 0; c < D; ++c) acc[c][t] = a[c];
        }
      }
      for (std::size_t t = 0; t < m; ++t) {
        R a[D];
        for (int c = 0; c < D; ++c) a[c] = acc[c][t];
        f.store(i0 + t, a);
      }
    }
  });
}

}  // namespace

template <class R>
ForcesLoops<R> forces_loops(CpuExec) {
  return {&cpu_long_range<R, 2>, &cpu_long_range<R, 3>, &cpu_for_each<ShortRangeVelocity<R, 2>>,
          &cpu_for_each<ShortRangeVelocity<R, 3>>};
}
template ForcesLoops<float> forces_loops<float>(CpuExec);
template ForcesLoops<double> forces_loops<double>(CpuExec);

}  // namespace ff::phoretic
