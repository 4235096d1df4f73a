// CPU loops of neighbors.verlet: the backend object's element loops and max-reduction
// (core/backend/exec_cpu.h) and a counting sort by cell.
#include <algorithm>
#include <vector>

#include "core/backend/exec_cpu.h"
#include "stages/neighbors/verlet/build.h"

namespace ff::neighbors {

namespace {

// Counting sort: O(N + cells), stable (particles of a cell stay in index order). An empty cell
// gets start = end = 0, as on the device (cuda.cu clears both and marks only occupied cells), so
// the fields hold the same bits on both backends.
void cpu_sort(std::size_t n, std::uint32_t ncells, const std::uint32_t* cell, std::uint32_t* order,
              std::uint32_t* cell_start, std::uint32_t* cell_end, CellSortScratch& /*scratch*/, CUstream_st* /*stream*/) {
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
  using E = CpuExec;
  return {{&E::for_each<AssignCell<R, 2>>, &E::for_each<BuildList<R, 2>>, &E::max<MovedTooFar<R, 2>>},
          {&E::for_each<AssignCell<R, 3>>, &E::for_each<BuildList<R, 3>>, &E::max<MovedTooFar<R, 3>>},
          &E::max<CountOf>,
          &cpu_sort};
}
template VerletLoops<float> verlet_loops<float>(CpuExec);
template VerletLoops<double> verlet_loops<double>(CpuExec);

}  // namespace ff::neighbors
