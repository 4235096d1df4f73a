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

// With the default outputs no thread walks a fan (a chain of ~7 dependent record loads, the
// kernel's critical path): first one pass over the Delaunay edges (edge_kernel: edge e's two
// records are adjacent, one 16-byte load) puts each half-edge h in the table of its origin v,
// slot k of v at table[k n + v] (the slot from an atomic count of v's half-edges, in any order),
// then the cells-only kernel loads v's half-edges and all their records at once and orders the
// fan in registers (kernel.h, fan_from_set()). The counts are zero between launches (the scratch
// is zeroed when allocated, and the cells' kernel zeroes each count it reads). A vertex of more
// than kTableSlots half-edges (rare: the mean is 6), or a set that is not walk()'s fan, walks.
constexpr int kTableSlots = kFanCache;
struct SharedFan {  // the ordered far ends, in shared memory: slot k of thread t at fan[k][t]
  static constexpr int capacity = kTableSlots;
  int* slot0;  // &fan[0][threadIdx.x]
  __device__ void put(int k, int u) const { slot0[k * kBlock] = u; }
  __device__ int get(int k) const { return slot0[k * kBlock]; }
};

__device__ void put_by_origin(int v, int h, int n, int* count, int* table) {
  if (unsigned(v) >= unsigned(n)) return;  // not a vertex: its fan (if any) walks
  const int k = atomicAdd(count + v, 1);
  if (k < kTableSlots) table[std::size_t(k) * unsigned(n) + unsigned(v)] = h;
}

__global__ void __launch_bounds__(kBlock) edge_kernel(unsigned n_edges, int n, const int4* records, int* count,
                                                      int* table) {
  const unsigned e = blockIdx.x * kBlock + threadIdx.x;
  if (e >= n_edges) return;
  const int4 r = __ldg(records + e);  // {origin(2e), next(2e), origin(2e + 1), next(2e + 1)}
  put_by_origin(r.x, int(2 * e), n, count, table);
  put_by_origin(r.z, int(2 * e + 1), n, count, table);
}

// One particle per thread; the cells-only kernel (Edges = false, the default outputs) orders each
// fan from the half-edges edge_kernel left in the table, then sums the cell. With metrics, each block adds its terms to sums.device with one
// atomic per sum (integers: the total does not depend on the order), and the last block to
// finish moves the totals to sums.out (pinned host memory) and zeroes the words for the next
// launch: no memset, no copy and no host wait on the stream (the stage reads sums.out after the
// step, behind a fence). Edges: whether f writes faces or circumcentres (without, the per-edge
// code is left out).
template <class R, bool Edges>
__global__ void __launch_bounds__(kBlock, kBlocksPerSm) cells_kernel(std::size_t n, CellGeometry<R> f, MetricSums sums,
                                                                     int* count, const int* table) {
  const std::size_t i = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  MetricTerms t;
  if constexpr (Edges) {
    // The faces and circumcentres need the half-edges' indices: the second walk follows the
    // records again, and without the cache's code the kernel keeps the plain walk's registers
    // (with it, 64 B spilled and the call was slower than main's: bench/experiments/README.md).
    if (i < n) t = f.template cell<true>(int(i), NoFanCache{});
  } else {
    // v's half-edges from the table (edge_kernel), all loads issued at once; then the fan.
    __shared__ int fan[kTableSlots][kBlock];
    if (i < n) {
      const int v = int(i);
      const int c = count[v];
      count[v] = 0;
      int hs[kTableSlots];
#pragma unroll
      for (int k = 0; k < kTableSlots; ++k) hs[k] = k < c ? __ldg(table + std::size_t(k) * n + i) : -1;
      const SharedFan cache{&fan[0][threadIdx.x]};
      auto w = f.template fan_from_set<kTableSlots>(v, c, hs, cache);
      if (w.deg == 0) w = f.walk(v, cache);  // walk() decides (a longer fan: sum() walks again)
      t = f.template sum<false>(v, w, cache);
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
    // walks: the counts (n words), then the table (kTableSlots n words).
    int* count = walks;
    int* table = walks + n;
    const unsigned n_edges = unsigned(3 * n);  // 6n half-edges on the torus
    edge_kernel<<<(n_edges + kBlock - 1) / kBlock, kBlock, 0, s>>>(n_edges, int(n),
                                                                    reinterpret_cast<const int4*>(f.he), count, table);
    cells_kernel<R, false><<<blocks, kBlock, 0, s>>>(n, f, sums, count, table);
  }
  FF_CUDA_CHECK_LAUNCH("launching voronoi.geometry's cells");
}

}  // namespace

template <class R>
GeometryLoops<R> geometry_loops(CudaExec) {
  return {&cells<R>, std::size_t(1 + kTableSlots)};
}
template GeometryLoops<float> geometry_loops<float>(CudaExec);
template GeometryLoops<double> geometry_loops<double>(CudaExec);

}  // namespace ff::voronoi
