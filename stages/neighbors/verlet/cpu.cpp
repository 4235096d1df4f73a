// CPU loops of neighbors.verlet: oneTBB element loops from core/backend/exec_cpu.h, a max-reduction
// and a counting sort by cell.
#include <oneapi/tbb/parallel_reduce.h>

#include <algorithm>
#include <vector>

#include "core/backend/exec_cpu.h"
#include "stages/neighbors/verlet/stage.h"

namespace ff::neighbors {

namespace {

template <class F>
std::uint32_t cpu_max(std::size_t n, const F& f, CUstream_st* /*stream*/) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 4096), std::uint32_t(0),
      [&](const tbb::blocked_range<std::size_t>& r, std::uint32_t m) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) m = std::max(m, f(i));
        return m;
      },
      [](std::uint32_t a, std::uint32_t b) { return std::max(a, b); });
}

// Counting sort: O(N + cells), stable (particles of a cell stay in index order). An empty cell
// gets start = end = 0, as on the device (cuda.cu clears both and marks only occupied cells), so
// the fields hold the same bits on both backends.
void cpu_sort(std::size_t n, std::uint32_t ncells, const std::uint32_t* cell, std::uint32_t* order,
              std::uint32_t* cell_start, std::uint32_t* cell_end, CUstream_st* /*stream*/) {
  std::fill(cell_end, cell_end + ncells, 0u);
  for (std::size_t i = 0; i < n; ++i) ++cell_end[cell[i]];  // counts
  std::uint32_t sum = 0;
  for (std::uint32_t c = 0; c < ncells; ++c) {
    const std::uint32_t count = cell_end[c];
    cell_start[c] = count ? sum : 0u;
    cell_end[c] = cell_start[c];  // fill pointer, ends at the cell's end
    sum += count;
  }
  for (std::size_t i = 0; i < n; ++i) order[cell_end[cell[i]]++] = std::uint32_t(i);
}

}  // namespace

template <class R>
VerletLoops<R> verlet_loops(CpuExec) {
  return {{&cpu_for_each<AssignCell<R, 2>>, &cpu_for_each<BuildList<R, 2>>, &cpu_max<MovedTooFar<R, 2>>},
          {&cpu_for_each<AssignCell<R, 3>>, &cpu_for_each<BuildList<R, 3>>, &cpu_max<MovedTooFar<R, 3>>},
          &cpu_max<CountOf>,
          &cpu_sort};
}
template VerletLoops<float> verlet_loops<float>(CpuExec);
template VerletLoops<double> verlet_loops<double>(CpuExec);

}  // namespace ff::neighbors
