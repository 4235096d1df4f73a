#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_reduce.h>

#include "core/backend/exec_cpu.h"
#include "stages/voronoi/geometry/stage.h"

namespace ff::voronoi {

namespace {

constexpr std::size_t kGrain = 2048;

// The cells, and with sums.out their metric terms summed in the same pass (integers: the same
// total for any split of the particles between threads).
template <class R>
void cells(std::size_t n, const CellGeometry<R>& f, MetricSums sums, CUstream_st* s) {
  if (!sums.out) return cpu_for_each<CellGeometry<R>, kGrain>(n, f, s);
  const MetricTerms t = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kGrain), MetricTerms{},
      [&](const tbb::blocked_range<std::size_t>& r, MetricTerms m) __attribute__((flatten)) {
        const CellGeometry<R> local = f;  // members in registers across the loop (cpu_for_each)
        for (std::size_t i = r.begin(); i != r.end(); ++i) m += local.cell(int(i));
        return m;
      },
      [](MetricTerms a, const MetricTerms& b) { return a += b; });
  sums.out[0] = t.area;
  sums.out[1] = t.area2;
  sums.out[2] = t.sides2;
}

}  // namespace

template <class R>
GeometryLoops<R> geometry_loops(CpuExec) {
  return {&cells<R>};
}
template GeometryLoops<float> geometry_loops<float>(CpuExec);
template GeometryLoops<double> geometry_loops<double>(CpuExec);

}  // namespace ff::voronoi
