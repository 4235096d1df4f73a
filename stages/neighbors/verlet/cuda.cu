// CUDA loops of neighbors.verlet: the backend object's element loops and max-reduction
// (core/backend/cuda/loop.cuh; it reads one word back: the rebuild decision and the capacity
// check need the answer on the host), and a stable radix sort by cell (CUB) followed by a kernel
// that marks cell ranges.
#include <cub/device/device_radix_sort.cuh>

#include <algorithm>

#include "core/backend/cuda/loop.cuh"
#include "stages/neighbors/verlet/build.h"

namespace ff::neighbors {

namespace {

__global__ void iota_kernel(std::size_t n, std::uint32_t* v) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) v[i] = std::uint32_t(i);
}

__global__ void cell_bounds_kernel(std::size_t n, const std::uint32_t* sorted_cell, std::uint32_t* start,
                                   std::uint32_t* end) {
  const std::size_t p = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (p >= n) return;
  const std::uint32_t c = sorted_cell[p];
  if (p == 0 || sorted_cell[p - 1] != c) start[c] = std::uint32_t(p);
  if (p + 1 == n || sorted_cell[p + 1] != c) end[c] = std::uint32_t(p + 1);
}

void cuda_sort(std::size_t n, std::uint32_t ncells, const std::uint32_t* cell, std::uint32_t* order,
               std::uint32_t* cell_start, std::uint32_t* cell_end, CellSortScratch& scratch, CUstream_st* stream) {
  FF_CUDA_CHECK(cudaMemsetAsync(cell_start, 0, ncells * sizeof(std::uint32_t), stream), "clearing cell ranges");
  FF_CUDA_CHECK(cudaMemsetAsync(cell_end, 0, ncells * sizeof(std::uint32_t), stream), "clearing cell ranges");
  if (n == 0) return;
  int bits = 1;
  while (bits < 32 && (std::uint64_t(1) << bits) < ncells) ++bits;
  std::uint32_t* keys_out = scratch.sorted_cell.get(n);
  std::uint32_t* values_in = scratch.index.get(n);
  std::size_t temp_bytes = 0;
  FF_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, temp_bytes, cell, keys_out, values_in, order, int(n), 0,
                                                bits, stream),
                "sizing the cell sort");
  // Never null: a null buffer would make the call below another size query.
  void* temp = scratch.temp.get(std::max<std::size_t>(temp_bytes, 1));
  constexpr int block = 256;
  const unsigned grid = unsigned((n + block - 1) / block);
  iota_kernel<<<grid, block, 0, stream>>>(n, values_in);
  FF_CUDA_CHECK_LAUNCH("launching iota (neighbors.verlet)");
  FF_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp, temp_bytes, cell, keys_out, values_in, order, int(n), 0, bits,
                                                stream),
                "sorting particles by cell");
  cell_bounds_kernel<<<grid, block, 0, stream>>>(n, keys_out, cell_start, cell_end);
  FF_CUDA_CHECK_LAUNCH("launching cell bounds (neighbors.verlet)");
}

}  // namespace

template <class R>
VerletLoops<R> verlet_loops(CudaExec) {
  using E = CudaExec;
  return {{&E::for_each<AssignCell<R, 2>>, &E::for_each<BuildList<R, 2>>, &E::max<MovedTooFar<R, 2>>},
          {&E::for_each<AssignCell<R, 3>>, &E::for_each<BuildList<R, 3>>, &E::max<MovedTooFar<R, 3>>},
          &E::max<CountOf>,
          &cuda_sort};
}
template VerletLoops<float> verlet_loops<float>(CudaExec);
template VerletLoops<double> verlet_loops<double>(CudaExec);

}  // namespace ff::neighbors
