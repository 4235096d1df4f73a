// CUDA loops of neighbors.verlet: element loops from core/backend/cuda/loop.cuh, a max-reduction that
// reads one word back (the rebuild decision and the capacity check need the answer on the
// host), and a stable radix sort by cell (CUB) followed by a kernel that marks cell ranges.
#include <cub/device/device_radix_sort.cuh>

#include "core/backend/cuda/loop.cuh"
#include "stages/neighbors/verlet/stage.h"

namespace ff::neighbors {

namespace {

template <class F>
__global__ void max_kernel(std::size_t n, F f, std::uint32_t* out) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  std::uint32_t v = i < n ? f(i) : 0u;
  for (int o = 16; o > 0; o >>= 1) v = max(v, __shfl_down_sync(0xffffffffu, v, o));
  if ((threadIdx.x & 31) == 0 && v) atomicMax(out, v);  // integer max: order-independent
}

template <class F>
std::uint32_t cuda_max(std::size_t n, const F& f, CUstream_st* stream) {
  if (n == 0) return 0;
  std::uint32_t* d_out = nullptr;
  FF_CUDA_CHECK(cudaMallocAsync(reinterpret_cast<void**>(&d_out), sizeof(std::uint32_t), stream),
                "allocating a reduction word");
  FF_CUDA_CHECK(cudaMemsetAsync(d_out, 0, sizeof(std::uint32_t), stream), "clearing a reduction word");
  constexpr int block = 256;
  max_kernel<F><<<unsigned((n + block - 1) / block), block, 0, stream>>>(n, f, d_out);
  FF_CUDA_CHECK_LAUNCH("launching a max-reduction (neighbors.verlet)");
  std::uint32_t h = 0;
  FF_CUDA_CHECK(cudaMemcpyAsync(&h, d_out, sizeof(h), cudaMemcpyDeviceToHost, stream), "reading a reduction word");
  FF_CUDA_CHECK(cudaFreeAsync(d_out, stream), "freeing a reduction word");
  FF_CUDA_CHECK(cudaStreamSynchronize(stream), "waiting for a max-reduction (neighbors.verlet)");
  return h;
}

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
               std::uint32_t* cell_start, std::uint32_t* cell_end, CUstream_st* stream) {
  FF_CUDA_CHECK(cudaMemsetAsync(cell_start, 0, ncells * sizeof(std::uint32_t), stream), "clearing cell ranges");
  FF_CUDA_CHECK(cudaMemsetAsync(cell_end, 0, ncells * sizeof(std::uint32_t), stream), "clearing cell ranges");
  if (n == 0) return;
  int bits = 1;
  while (bits < 32 && (std::uint64_t(1) << bits) < ncells) ++bits;
  std::uint32_t *keys_out = nullptr, *values_in = nullptr;
  void* temp = nullptr;
  std::size_t temp_bytes = 0;
  FF_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, temp_bytes, cell, keys_out, values_in, order, int(n), 0,
                                                bits, stream),
                "sizing the cell sort");
  FF_CUDA_CHECK(cudaMallocAsync(reinterpret_cast<void**>(&keys_out), n * sizeof(std::uint32_t), stream),
                "allocating the cell sort");
  FF_CUDA_CHECK(cudaMallocAsync(reinterpret_cast<void**>(&values_in), n * sizeof(std::uint32_t), stream),
                "allocating the cell sort");
  FF_CUDA_CHECK(cudaMallocAsync(&temp, temp_bytes, stream), "allocating the cell sort");
  constexpr int block = 256;
  const unsigned grid = unsigned((n + block - 1) / block);
  iota_kernel<<<grid, block, 0, stream>>>(n, values_in);
  FF_CUDA_CHECK_LAUNCH("launching iota (neighbors.verlet)");
  FF_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp, temp_bytes, cell, keys_out, values_in, order, int(n), 0, bits,
                                                stream),
                "sorting particles by cell");
  cell_bounds_kernel<<<grid, block, 0, stream>>>(n, keys_out, cell_start, cell_end);
  FF_CUDA_CHECK_LAUNCH("launching cell bounds (neighbors.verlet)");
  FF_CUDA_CHECK(cudaFreeAsync(temp, stream), "freeing the cell sort");
  FF_CUDA_CHECK(cudaFreeAsync(values_in, stream), "freeing the cell sort");
  FF_CUDA_CHECK(cudaFreeAsync(keys_out, stream), "freeing the cell sort");
}

}  // namespace

template <class R>
VerletLoops<R> verlet_loops(CudaExec) {
  return {{&cuda_for_each<AssignCell<R, 2>>, &cuda_for_each<BuildList<R, 2>>, &cuda_max<MovedTooFar<R, 2>>},
          {&cuda_for_each<AssignCell<R, 3>>, &cuda_for_each<BuildList<R, 3>>, &cuda_max<MovedTooFar<R, 3>>},
          &cuda_max<CountOf>,
          &cuda_sort};
}
template VerletLoops<float> verlet_loops<float>(CudaExec);
template VerletLoops<double> verlet_loops<double>(CudaExec);

}  // namespace ff::neighbors
