// CPU loops of phoretic.forces. Long range: a blocked all-pairs loop — blocks of 64 targets
// (one oneTBB task each) sweep tiles of 512 sources, so a tile's positions and charges stay in
// cache while 64 accumulators use them; each target still adds its sources in ascending order,
// exactly as LongRangeVelocity::operator() does. Short range: the element loop.
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>
#include <vector>

#include "core/exec_cpu.h"
#include "plugins/phoretic/forces/cpu.h"

namespace ff::phoretic {

namespace {

template <class R, int D>
void cpu_long_range(const LongRangeVelocity<R, D>& f, CUstream_st* /*stream*/) {
  constexpr std::size_t kTargets = 64, kSources = 512;
  const std::size_t n = f.n;
  std::vector<R> alpha(n);
  for (std::size_t k = 0; k < n; ++k) alpha[k] = f.alpha_of(k);
  const std::size_t blocks = (n + kTargets - 1) / kTargets;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t b = r.begin(); b != r.end(); ++b) {
      const std::size_t i0 = b * kTargets, i1 = std::min(n, i0 + kTargets);
      R acc[kTargets][D] = {};
      for (std::size_t k0 = 0; k0 < n; k0 += kSources) {
        const std::size_t k1 = std::min(n, k0 + kSources);
        for (std::size_t i = i0; i < i1; ++i) {
          const R* xi = &f.position[i * D];
          R* a = acc[i - i0];
          for (std::size_t k = k0; k < k1; ++k)
            if (k != i) f.add(a, xi, &f.position[k * D], alpha[k]);
        }
      }
      for (std::size_t i = i0; i < i1; ++i) f.store(i, acc[i - i0]);
    }
  });
}

}  // namespace

template <class R>
ForcesLoops<R> cpu_forces_loops() {
  return {&cpu_long_range<R, 2>, &cpu_long_range<R, 3>, &cpu_for_each<ShortRangeVelocity<R, 2>>,
          &cpu_for_each<ShortRangeVelocity<R, 3>>};
}
template ForcesLoops<float> cpu_forces_loops<float>();
template ForcesLoops<double> cpu_forces_loops<double>();

}  // namespace ff::phoretic
