// CUDA loop of overlap_correct: one persistent cooperative kernel per step runs the whole
// iteration (gather, grid barrier, decide, apply, grid barrier, ...) on the device and reports
// every gather's counters with one read-back. Compiled with -fmad=false (CMakeLists.txt):
// without contracted multiply-adds the per-particle math (kernel.h) rounds exactly as on the
// CPU, so both backends produce the same bits in double.
//
// Work lists. Block b owns the particles [b·T, (b+1)·T). Iteration 0 gathers all of them.
// A gather flags (one byte per particle, in the array of the next iteration) each particle that
// had an overlapping edge, and every neighbour of each particle that moved; iteration k + 1
// gathers only the flagged particles of the block's tile (compacted in index order with a block
// scan, the flags cleared as they are read). Any edge that overlaps at k + 1 overlapped at k
// (both ends flagged) or has a moved end (the other end flagged), so every particle left out
// would have gathered d = 0 and no pairs: the result is the same as gathering everyone, the
// CPU loop's result (kernel.h: pushes are summed in 64-bit fixed point, so the CPU's edge passes
// and these walks give the same bits). The particles a block moves are kept in a block-private
// list for its apply. (An edge-pass version of this kernel was tried and is not correct yet:
// experiments/gpu-edge-pass-fixed-point.patch, PERF.md.)
//
// Counters: per-thread sums, a block reduction, then one integer atomic per block into one of
// kShards copies of each counter (spreading same-address atomics); after the barrier every
// block sums the shards and takes the same decision (keeps_going). Integer sums do not depend
// on the order, so neither does anything else.
#include <cooperative_groups.h>
#include <cuda_runtime.h>

#include <algorithm>

#include "core/cuda/check.h"
#include "stages/overlap_correct/cuda.cuh"

namespace cg = cooperative_groups;

namespace ff::overlap {

namespace {

constexpr int kThreads = 256;
constexpr int kWarps = kThreads / 32;
constexpr int kShards = 8;
constexpr int kShardStride = 4;  // u64 between shards: one 32-byte sector each
constexpr std::size_t kSlotWords = std::size_t(kBatch) * kCounters * kShards * kShardStride;
constexpr std::size_t kResultWords = std::size_t(kBatch) * kCounters + 1;  // + gathers run

using u64 = unsigned long long;

template <class R>
struct Args {
  Problem<R> p;
  std::uint8_t* flags[2];  // 2 x grid·tile bytes, one per particle (padding never set)
  int* cand;               // grid·tile: each block's candidates, tile-private
  int* moved;              // grid·tile: each block's moved particles
  double2* disp;           // grid·tile: their displacements
  u64* slots;              // kBatch x kCounters x kShards (sharded counters, zeroed per launch)
  u64* result;             // kBatch x kCounters + 1 (block 0 writes the sums and the gather count)
  int tile;                // particles per block, a multiple of 16
  long long k0;
  long long max_iterations;
};

// Exclusive block-wide prefix sum of c; *total gets the sum. Every thread must call it.
__device__ int block_scan(int c, int* total, int* s_warp) {
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  int x = c;
#pragma unroll
  for (int o = 1; o < 32; o <<= 1) {
    const int y = __shfl_up_sync(0xffffffffu, x, o);
    if (lane >= o) x += y;
  }
  if (lane == 31) s_warp[warp] = x;
  __syncthreads();
  int before = 0, sum = 0;
#pragma unroll
  for (int w = 0; w < kWarps; ++w) {
    const int t = s_warp[w];
    if (w < warp) before += t;
    sum += t;
  }
  __syncthreads();
  *total = sum;
  return before + x - c;
}

// The flagged particles of [t0, t0 + tile) into cand, in index order; clears those flags.
__device__ int compact(std::uint8_t* flags, int t0, int tile, int* cand, int* s_warp) {
  int count = 0;
  for (int base = 0; base < tile; base += 16 * kThreads) {
    const int off = base + 16 * int(threadIdx.x);
    uint4 w = make_uint4(0, 0, 0, 0);
    auto* p = reinterpret_cast<uint4*>(flags + t0 + off);
    if (off < tile) w = __ldcg(p);
    const int c = __popc(w.x) + __popc(w.y) + __popc(w.z) + __popc(w.w);  // bytes are 0 or 1
    int total;
    int at = count + block_scan(c, &total, s_warp);
    if (c) {
      const unsigned words[4] = {w.x, w.y, w.z, w.w};
#pragma unroll
      for (int q = 0; q < 4; ++q)
#pragma unroll
        for (int b = 0; b < 4; ++b)
          if ((words[q] >> (8 * b)) & 0xffu) cand[at++] = t0 + off + 4 * q + b;
      *p = make_uint4(0, 0, 0, 0);
    }
    count += total;
  }
  return count;
}

__device__ u64 warp_sum(u64 x) {
#pragma unroll
  for (int o = 16; o > 0; o >>= 1) x += __shfl_down_sync(0xffffffffu, x, o);
  return x;
}

template <class R, int MinBlocks>
__global__ void __launch_bounds__(kThreads, MinBlocks) correct_kernel(Args<R> a) {
  cg::grid_group grid = cg::this_grid();
  __shared__ int s_warp[kWarps];
  __shared__ int s_moved;
  __shared__ u64 s_red[kCounters][kWarps];
  __shared__ u64 s_tot[kCounters];

  const Mesh<R>& mesh = a.p.mesh;
  const int n = int(a.p.n);
  const int t0 = int(blockIdx.x) * a.tile;
  const int t1 = min(n, t0 + a.tile);
  const std::size_t mine = std::size_t(blockIdx.x) * a.tile;
  int* cand = a.cand + mine;
  int* moved = a.moved + mine;
  double2* disp = a.disp + mine;
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  const int shard = int(blockIdx.x % kShards) * kShardStride;

  for (int j = 0; j < kBatch; ++j) {
    const long long k = a.k0 + j;
    std::uint8_t* next = a.flags[(k + 1) & 1];
    const int count = k == 0 ? max(0, t1 - t0) : compact(a.flags[k & 1], t0, a.tile, cand, s_warp);
    if (threadIdx.x == 0) s_moved = 0;
    __syncthreads();

    u64 c[kCounters] = {0, 0, 0, 0};
    for (int i = int(threadIdx.x); i < count; i += kThreads) {
      const int v = k == 0 ? t0 + i : cand[i];
      const VertexPush q = mesh.gather(v);
      c[kBad] += q.bad;
      c[kPairs] += q.pairs;
      c[kCorrection] += mesh.fixed_len(q.len);
      c[kBroken] += q.broken;
      if (q.touched) next[v] = 1;
      if (q.dx != 0 || q.dy != 0) {
        const int m = atomicAdd(&s_moved, 1);
        moved[m] = v;
        disp[m] = make_double2(q.dx, q.dy);
        mesh.for_each_neighbour(v, [&](int u, int) { next[u] = 1; });
      }
    }
#pragma unroll
    for (int q = 0; q < kCounters; ++q) {
      const u64 s = warp_sum(c[q]);
      if (lane == 0) s_red[q][warp] = s;
    }
    __syncthreads();
    if (threadIdx.x < kCounters) {
      u64 s = 0;
#pragma unroll
      for (int w = 0; w < kWarps; ++w) s += s_red[threadIdx.x][w];
      if (s) atomicAdd(a.slots + (std::size_t(j) * kCounters + threadIdx.x) * kShards * kShardStride + shard, s);
    }
    grid.sync();

    if (threadIdx.x < kCounters) {
      const u64* p = a.slots + (std::size_t(j) * kCounters + threadIdx.x) * kShards * kShardStride;
      u64 s = 0;
#pragma unroll
      for (int h = 0; h < kShards; ++h) s += __ldcg(p + h * kShardStride);
      s_tot[threadIdx.x] = s;
      if (blockIdx.x == 0) a.result[std::size_t(j) * kCounters + threadIdx.x] = s;
    }
    if (blockIdx.x == 0 && threadIdx.x == 0) a.result[std::size_t(kBatch) * kCounters] = u64(j + 1);
    __syncthreads();
    const std::uint64_t tot[kCounters] = {s_tot[0], s_tot[1], s_tot[2], s_tot[3]};
    if (!keeps_going(tot, k, a.max_iterations)) {
      // The step ends here: clear this tile's flags for the next iteration so the next step
      // starts from clean flags (this iteration's were cleared as they were read).
      for (int off = 16 * int(threadIdx.x); off < a.tile; off += 16 * kThreads)
        *reinterpret_cast<uint4*>(next + t0 + off) = make_uint4(0, 0, 0, 0);
      return;
    }

    const int nm = s_moved;
    for (int i = int(threadIdx.x); i < nm; i += kThreads) {
      const double2 d = disp[i];
      apply_one(a.p.pos, a.p.image, a.p.box, std::size_t(moved[i]), d.x, d.y);
    }
    if (j + 1 == kBatch) return;  // the host launches the next batch (flags for it are set)
    grid.sync();
  }
}

struct DevWorkspace {
  std::size_t n = 0;
  int grid[2] = {0, 0};  // per precision (float, double): co-resident blocks used
  int tile[2] = {0, 0};
  std::size_t cap = 0;   // grid·tile of the allocation (≥ both)
  std::uint8_t* flags = nullptr;  // 2 x cap
  int* cand = nullptr;
  int* moved = nullptr;
  double2* disp = nullptr;
  u64* slots = nullptr;
  u64* result = nullptr;
  u64* host = nullptr;  // pinned copy of result
};

template <class T>
T* dev_alloc(std::size_t count, const char* what) {
  void* p = nullptr;
  FF_CUDA_CHECK(cudaMalloc(&p, std::max<std::size_t>(count, 1) * sizeof(T)), what);
  return static_cast<T*>(p);
}

// Blocks and tile for n particles: at most what fits on the device at once (a cooperative
// launch needs every block resident), tiles of at least 256 particles, a multiple of 16.
// 4 blocks of 256 per SM (64 registers): measured on the H100 against 1, 6 and 8 (the last two
// spill) at N = 2^20; 1.5 ms per step against 2.2, 3.4 and 3.2.
constexpr int kMinBlocks = 4;
template <class R>
void* kernel_ptr() {
  return reinterpret_cast<void*>(correct_kernel<R, kMinBlocks>);
}

template <class R>
void shape(std::size_t n, int& grid, int& tile) {
  int dev = 0, sms = 0, per_sm = 0, coop = 0;
  FF_CUDA_CHECK(cudaGetDevice(&dev), "overlap_correct: current device");
  FF_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, dev), "overlap_correct: SM count");
  FF_CUDA_CHECK(cudaDeviceGetAttribute(&coop, cudaDevAttrCooperativeLaunch, dev), "overlap_correct: cooperative");
  if (!coop) throw RunError("overlap_correct: the CUDA device does not support cooperative launches");
  FF_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, kernel_ptr<R>(), kThreads, 0),
                "overlap_correct: occupancy");
  const std::size_t most = std::size_t(std::max(1, per_sm)) * std::size_t(sms);
  const std::size_t want = std::max<std::size_t>(1, (n + 255) / 256);
  grid = int(std::min(most, want));
  const std::size_t t = (n + grid - 1) / grid;
  tile = int(std::max<std::size_t>(16, (t + 15) / 16 * 16));
}

void dev_destroy(void* p);

void* dev_create(std::size_t n) {
  auto* w = new DevWorkspace;
  try {
    w->n = n;
    shape<float>(n, w->grid[0], w->tile[0]);
    shape<double>(n, w->grid[1], w->tile[1]);
    w->cap = std::max(std::size_t(w->grid[0]) * w->tile[0], std::size_t(w->grid[1]) * w->tile[1]);
    w->flags = dev_alloc<std::uint8_t>(2 * w->cap, "allocating overlap_correct flags");
    FF_CUDA_CHECK(cudaMemset(w->flags, 0, 2 * w->cap), "clearing overlap_correct flags");
    w->cand = dev_alloc<int>(w->cap, "allocating overlap_correct work lists");
    w->moved = dev_alloc<int>(w->cap, "allocating overlap_correct work lists");
    w->disp = dev_alloc<double2>(w->cap, "allocating overlap_correct displacements");
    w->slots = dev_alloc<u64>(kSlotWords, "allocating overlap_correct counters");
    w->result = dev_alloc<u64>(kResultWords, "allocating overlap_correct counters");
    FF_CUDA_CHECK(cudaMallocHost(&w->host, kResultWords * sizeof(u64)), "allocating overlap_correct counters");
  } catch (...) {
    dev_destroy(w);  // every pointer starts null, so a partial allocation frees cleanly
    throw;
  }
  return w;
}

void dev_destroy(void* p) {
  auto* w = static_cast<DevWorkspace*>(p);
  cudaFree(w->flags);
  cudaFree(w->cand);
  cudaFree(w->moved);
  cudaFree(w->disp);
  cudaFree(w->slots);
  cudaFree(w->result);
  cudaFreeHost(w->host);
  delete w;
}

template <class R>
void dev_iterate(void* ws, const Problem<R>& p, std::int64_t k0, std::int64_t max_iterations, Batch& out,
                 CUstream_st* s) {
  auto* w = static_cast<DevWorkspace*>(ws);
  const int r = sizeof(R) == 8 ? 1 : 0;
  Args<R> a{p,
            {w->flags, w->flags + w->cap},
            w->cand,
            w->moved,
            w->disp,
            w->slots,
            w->result,
            w->tile[r],
            static_cast<long long>(k0),
            static_cast<long long>(max_iterations)};
  FF_CUDA_CHECK(cudaMemsetAsync(w->slots, 0, kSlotWords * sizeof(u64), s), "clearing overlap_correct counters");
  void* args[] = {&a};
  FF_CUDA_CHECK(cudaLaunchCooperativeKernel(kernel_ptr<R>(), dim3(w->grid[r]),
                                            dim3(kThreads), args, 0, s),
                "launching overlap_correct");
  FF_CUDA_CHECK(cudaMemcpyAsync(w->host, w->result, kResultWords * sizeof(u64), cudaMemcpyDeviceToHost, s),
                "reading overlap_correct counters");
  FF_CUDA_CHECK(cudaStreamSynchronize(s), "waiting for overlap_correct");
  out.gathers = int(w->host[std::size_t(kBatch) * kCounters]);
  for (int j = 0; j < out.gathers; ++j)
    for (int c = 0; c < kCounters; ++c) out.counters[j][c] = w->host[std::size_t(j) * kCounters + c];
}

}  // namespace

template <class R>
Ops<R> cuda_ops() {
  return {&dev_create, &dev_destroy, &dev_iterate<R>};
}
template Ops<float> cuda_ops<float>();
template Ops<double> cuda_ops<double>();

}  // namespace ff::overlap
