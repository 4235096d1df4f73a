#include "core/backend/cuda/loop.cuh"
#include "stages/voronoi/geometry/stage.h"

namespace ff::voronoi {

namespace {

constexpr int kBlock = 256;
// Four blocks (32 warps) per SM instead of the three that 74 registers allow: registers capped
// at 64 (the cells-only kernel spills 24 B, the faces kernel 8 B), more fan walks in flight to
// hide their chains of dependent loads (measured: bench/experiments/README.md, "voronoi.geometry
// CUDA variants"; two particles a thread at three blocks lost).
constexpr int kBlocksPerSm = 4;

// With the default outputs the first walks (kernel.h, walk(): a chain of dependent 8-byte record
// loads, few registers) run in their own kernel at twice the summing kernel's occupancy, so that
// twice as many chains are in flight. It leaves each fan's far ends in a table in global memory
// (the stage's scratch), slot k of particle v at table[k n + v] (a warp's stores and loads of one
// slot are coalesced), rotated to start at the fan's lowest half-edge (the summing walk's first),
// and {deg, hmin} in walks[v]. A fan longer than kTableSlots (rare: the mean is 6) walks its
// records again in sum().
constexpr int kTableSlots = kFanCache;
struct IndexFan {  // walk_kernel's: the far ends in walk order, in shared memory
  static constexpr int capacity = kTableSlots;
  int* slot0;  // &fan[0][threadIdx.x]
  __device__ void put(int k, int u) const { slot0[k * kBlock] = u; }
  __device__ int get(int k) const { return slot0[k * kBlock]; }
};
struct TableFan {  // cells_kernel's: the rotated far ends in global memory
  static constexpr int capacity = kTableSlots;
  const int* slot0;  // &table[v]
  std::size_t stride;
  __device__ int get(int k) const { return __ldg(slot0 + k * stride); }
};

template <class R>
__global__ void __launch_bounds__(kBlock, 2 * kBlocksPerSm) walk_kernel(std::size_t n, CellGeometry<R> f, int* table,
                                                                         int2* walks) {
  const std::size_t i = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  if (i >= n) return;
  __shared__ int fan[kTableSlots][kBlock];
  const IndexFan c{&fan[0][threadIdx.x]};
  const auto w = f.walk(int(i), c);
  walks[i] = make_int2(w.deg, w.hmin);
  if (w.deg > kTableSlots) return;
  int j = w.kmin;
  for (int k = 0; k < w.deg; ++k) {
    table[k * n + i] = c.get(j);
    if (++j == w.deg) j = 0;
  }
}

// One particle per thread; the cells-only kernel (Edges = false, the default outputs) sums each
// cell from the fan walk_kernel left in the table. With metrics, each block adds its terms to sums.device with one
// atomic per sum (integers: the total does not depend on the order), and the last block to
// finish moves the totals to sums.out (pinned host memory) and zeroes the words for the next
// launch: no memset, no copy and no host wait on the stream (the stage reads sums.out after the
// step, behind a fence). Edges: whether f writes faces or circumcentres (without, the per-edge
// code is left out).
template <class R, bool Edges>
__global__ void __launch_bounds__(kBlock, kBlocksPerSm) cells_kernel(std::size_t n, CellGeometry<R> f, MetricSums sums,
                                                                     const int* table, const int2* walks) {
  using Walk = typename CellGeometry<R>::FanWalk;
  const std::size_t i = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  MetricTerms t;
  if constexpr (Edges) {
    // The faces and circumcentres need the half-edges' indices: the second walk follows the
    // records again, and without the cache's code the kernel keeps the plain walk's registers
    // (with it, 64 B spilled and the call was slower than main's: bench/experiments/README.md).
    if (i < n) t = f.template cell<true>(int(i), NoFanCache{});
  } else {
    // The walks ran in walk_kernel: sum() reads the fan's far ends from the table, rotated so
    // that slot k holds the k-th far end from the fan's lowest half-edge (kmin = 0 here).
    if (i < n) {
      const int2 w = __ldg(walks + i);
      t = f.template sum<false>(int(i), Walk{w.x, w.y, 0}, TableFan{table + i, n});
    }
  }
  if (!sums.device) return;
  unsigned long long v[3] = {t.area, t.area2, t.sides2};
  __shared__ unsigned long long warps[3][kBlock / 32];
  for (int k = 0; k < 3; ++k) {
    for (int o = 16; o > 0; o >>= 1) v[k] += __shfl_down_sync(0xffffffffu, v[k], o);
    if ((threadIdx.x & 31) == 0) warps[k][threadIdx.x >> 5] = v[k];
  }
  __syncthreads();
  if (threadIdx.x != 0) return;
  auto* d = reinterpret_cast<unsigned long long*>(sums.device);
  for (int k = 0; k < 3; ++k) {
    unsigned long long b = 0;
    for (int w = 0; w < kBlock / 32; ++w) b += warps[k][w];
    atomicAdd(d + k, b);
  }
  __threadfence();  // this block's sums before its count
  if (atomicAdd(d + 3, 1ull) != gridDim.x - 1) return;
  // The last block: every other block's sums are in.
  __threadfence();
  sums.out[0] = atomicExch(d, 0ull);
  sums.out[1] = atomicExch(d + 1, 0ull);
  sums.out[2] = atomicExch(d + 2, 0ull);
  atomicExch(d + 3, 0ull);
}

template <class R>
void cells(std::size_t n, const CellGeometry<R>& f, MetricSums sums, std::int32_t* walks, CUstream_st* s) {
  if (n == 0) return;
  const unsigned blocks = unsigned((n + kBlock - 1) / kBlock);
  if (f.face_length || f.circumcenter) {
    cells_kernel<R, true><<<blocks, kBlock, 0, s>>>(n, f, sums, nullptr, nullptr);
  } else {
    // walks: {deg, hmin} of each particle (2n words), then the table (kTableSlots n words).
    int2* fan_walks = reinterpret_cast<int2*>(walks);
    int* table = walks + 2 * n;
    walk_kernel<R><<<blocks, kBlock, 0, s>>>(n, f, table, fan_walks);
    cells_kernel<R, false><<<blocks, kBlock, 0, s>>>(n, f, sums, table, fan_walks);
  }
  FF_CUDA_CHECK_LAUNCH("launching voronoi.geometry's cells");
}

}  // namespace

template <class R>
GeometryLoops<R> geometry_loops(CudaExec) {
  return {&cells<R>, std::size_t(2 + kTableSlots)};
}
template GeometryLoops<float> geometry_loops<float>(CudaExec);
template GeometryLoops<double> geometry_loops<double>(CudaExec);

}  // namespace ff::voronoi
