// The parts of overlap_correct's kernels that the persistent kernel (correct_kernel.cuh), its tail
// in shared memory (shared_tail.cuh) and the wide first iterations (wide_kernels.cuh) share: the
// block size and counter layout, the sums, what a gather found (count_gather, take_gather), the
// kernel's arguments, the team barriers and the sums' loads. Device code; included through
// correct_kernel.cuh, compiled with -fmad=false as cuda.cu is (CMakeLists.txt).
#pragma once
#include <cooperative_groups.h>
#include <cuda_runtime.h>

#include <algorithm>

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/loop.cuh"
#include "core/backend/cuda/pdl.cuh"
#include "core/backend/device.h"
#include "stages/overlap_correct/stage.h"
#include "stages/overlap_correct/neighbor_lists.cuh"
#include "stages/overlap_correct/work_lists.cuh"

namespace cg = cooperative_groups;

namespace ff::overlap {

namespace {

constexpr int kThreads = 512;  // the grid kernel's block size (team_shape.cuh: kMinBlocks)
constexpr int kShards = 8;
constexpr int kShardStride = 4;  // u64 between shards: one 32-byte sector each
// The counters a kernel sums: kernel.h's, kTouched (the last) only with the touched field (Mark),
// then one device-side counter: particles moved (summed over the blocks like the others; decides
// when the tail starts, not reported to the host).
template <bool Mark>
struct Sums {
  static constexpr int kReported = Mark ? kCounters : kTouched;
  static constexpr int kMoved = kReported, kAll = kReported + 1;
};
static_assert(kTouched == kCounters - 1, "kTouched is the counter left out without the touched field");
constexpr int kDevCounters = kCounters + 1;  // the most a kernel sums (the slots' layout)
constexpr std::size_t kSlotWords = std::size_t(kDeviceBatch) * kDevCounters * kShards * kShardStride;
constexpr std::size_t kResultWords = std::size_t(kDeviceBatch) * kCounters + 1;  // + gathers run
// Iterations after one that moved at most this many particles run in block 0 alone
// (bench/overlap_correct-PERF.md). A run alone's cluster (kClusterTailTeam blocks: team_shape.cuh's
// kClusterBlocks) keeps its cheaper iterations longer (bench/experiments/README.md, session 26's
// tail thresholds); the sweeps' smaller clusters keep kTailMoved, as they were measured.
constexpr int kTailMoved = 512;
constexpr int kClusterTailMoved = 256;
constexpr int kClusterTailTeam = 16;
// Block 0 holds the last kRowsHeld iterations' sums in shared memory and stores them to result
// (pinned host memory) when the run is full and when the launch ends, not after each iteration:
// a store over the bus, followed by the fence of the next team barrier, could hold that barrier
// until the store's round trip is done.
constexpr int kRowsHeld = 32;

using u64 = unsigned long long;

// What a gather of v found, added to a thread's counters c (at least Sums<Mark>::kReported of
// them). The touched field (Mark): iteration 0 (first) gathers every particle and writes each
// entry, later ones set those they touch (only v's gatherer writes v's entry in an iteration).
template <bool Mark, class Ov, int K>
__device__ __forceinline__ void count_gather(u64 (&c)[K], const Ov& ov, const VertexPush& q,
                                             std::uint8_t* touched, int v, bool first) {
  c[kBad] += q.bad;
  c[kPairs] += q.pairs;
  c[kCorrection] += ov.fixed_len(q.len);
  c[kBroken] += q.broken;
  if constexpr (Mark) {
    if (q.touched && (first || !touched[v])) ++c[kTouched];
    if (q.touched || first) touched[v] = std::uint8_t(q.touched);
  }
}

// What a gather of v found, as the kernel and the shared tail take it: counted (count_gather),
// and, when v touched an overlap, a slot m of the iteration's list from *listed and
// `list(m, moves, x, crossed)`: where a moving v goes (x, wrapped, crossed: the box crossings),
// computed from where the gather read it, so that the apply only stores it.
template <bool Mark, class R, class Ov, int K, class List>
__device__ __forceinline__ void take_gather(u64 (&c)[K], const Ov& ov, const PeriodicBox<R>& box, const VertexPush& q,
                                            std::uint8_t* touched, int v, bool first, int* listed, List list) {
  count_gather<Mark>(c, ov, q, touched, v, first);
  if (!q.touched) return;
  const bool moves = q.dx != 0 || q.dy != 0;
  const int m = atomicAdd(listed, 1);
  R x[2] = {R(0), R(0)};
  int crossed[2] = {0, 0};
  if (moves) {
    const double d[2] = {q.dx, q.dy};
    const R x0[2] = {R(q.x), R(q.y)};  // exact: load_xy widened them from R
    moved_from<2>(x0, box, d, x, crossed);
  }
  list(m, moves, x, crossed);
}

template <class R, bool Walls>
struct Args {
  Problem<R> p;
  Overlaps<R, Walls> ov;   // p.overlaps with the wall code compiled in or out
  std::uint8_t* marks;     // grid·tile bytes, one per particle (padding never set): next candidates
  int* cand;               // grid·tile: each block's candidates, tile-private; in the tail, the claimed
  int* seed;               // grid·tile: each block's touched particles, v if it moved, ~v if not
  double2* disp;           // grid·tile: where the moved ones go (moved_from), in the order of seed
  char2* crossed;          // grid·tile: the box crossings that adds to their image counts
  int* nb;                 // kCached x grid·tile: each particle's neighbours, filled in iteration 0
  std::uint8_t* degree;    // grid·tile: how many (kWalk: more than kCached, walk the fan)
  int* fan;                // kCached x grid·tile: the half-edges of each listed fan, kept across steps
  u64* slots;              // kDeviceBatch x Sums::kAll x kShards (sharded counters, zero at launch)
  u64* claims;             // entries of cand claimed by the check that starts the tail (zero at launch)
  u64* next_slots;         // the other launch's slots and claims (kSlotWords + 1): zeroed here
  u64* result;             // kDeviceBatch x kCounters + 1 (block 0 writes the sums and the gather count):
                           // pinned host memory, written directly (no copy after the kernel), in
                           // runs of kRowsHeld iterations
  std::uint8_t* state;     // grid·tile, by particle: what a wide gather found (WideState), for its
                           // apply and check; disp and crossed are indexed by particle there too
  R* next;                 // 2 x grid·tile, or null: the positions after the iteration's moves
                           // (the check reads them while the apply writes pos; see the kernel)
  Overlaps<R, Walls> ov_check;  // ov for the check: its positions are next (or, without, p's)
  int tile;                // particles per block, a multiple of 16
  int j0;                  // the batch's first iteration this kernel runs: those before ran in the
                           // wide kernels (run_wide), their counters in slots
  long long k0;
  long long max_iterations;
  long long next_zero;     // words of next_slots to zero (those the last launch used), and its claims
};

// Particle v's position (x, y) stored as one vector (the apply's only store besides rare image
// counts).
template <class R>
__device__ void store_xy(R* pos, int v, double x, double y) {
  if constexpr (sizeof(R) == 8)
    reinterpret_cast<double2*>(pos)[v] = make_double2(x, y);
  else
    reinterpret_cast<float2*>(pos)[v] = make_float2(float(x), float(y));
}

// A block's gathers (checks) go to lane groups when it has at most this many particles to do
// (a quarter of its threads: 128 in the grid's and the cluster's blocks of 512, two passes of
// groups), else one thread each: a group shortens one particle's chain of loads, but puts 8x
// fewer particles in flight, and each further pass of groups is another chain after the first,
// where threads take up to Threads particles at once. An eighth (one pass) was the best share
// from session 21 to 27 (H100 and H200 measurements, from half the threads to an eighth:
// bench/overlap_correct-PERF.md, bench/experiments/README.md "tail21"); with the grid's tiles of
// 128 a quarter is up to 1.4 % faster at 2^11-2^14 and the same elsewhere (session 28).
template <int Threads>
constexpr int kGroupBelow = Threads / 4;

// Who runs a launch's iterations (Team): the grid (kGrid: a cooperative launch of every block that
// fits on the device, grid barriers between phases) or a thread-block cluster of Team blocks
// (sm_90; cluster.sync(), a barrier in the hardware, where a grid barrier is atomics on a global
// word and a spin: bench/overlap_correct-PERF.md has both's costs). Team blocks do the work of the grid's
// with fewer threads; small systems (DeviceLoops::team_for) have too little work to fill the grid,
// and there the barriers (two or three per iteration) and the cooperative launch are the time.
constexpr int kGrid = 0;

// A barrier among the launch's blocks, with the memory ordering of grid.sync: writes before it
// (positions, marks, counters) are seen by every read after it. The cluster's barrier is a
// release (arrive) and an acquire (wait) at cluster scope, which order global memory too.
template <int Team>
__device__ void team_sync() {
  if constexpr (Team == kGrid) {
    cg::this_grid().sync();
  } else {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
    cg::this_cluster().sync();
#else
    __trap();  // never launched: the host launches clusters only on devices that have them
#endif
  }
}

// The address of p (a variable in this block's shared memory) in block `rank`'s shared memory
// (mapa), for ld/st/atom.shared::cluster. (cg's cluster.map_shared_rank goes through a generic
// address, and cost the team kernel up to 128 registers with 8-32 B of spills, against ~100-112
// and none.)
__device__ __forceinline__ unsigned in_block(const void* p, unsigned rank) {
  unsigned remote = 0;
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  asm("mapa.shared::cluster.u32 %0, %1, %2;" : "=r"(remote) : "r"(unsigned(__cvta_generic_to_shared(p))), "r"(rank));
#else
  __trap();
#endif
  return remote;
}

// The u64 at p (in this block's shared memory) in the shared memory of the cluster's block
// `rank` (sm_90's distributed shared memory).
__device__ u64 load_in_block(const u64* p, int rank) {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  u64 v;
  asm volatile("ld.shared::cluster.u64 %0, [%1];" : "=l"(v) : "r"(in_block(p, unsigned(rank))) : "memory");
  return v;
#else
  __trap();
  return 0;
#endif
}

// Counter q of iteration j of a launch (All counters an iteration), summed over its shards.
template <int All>
__device__ u64 slot_total(const u64* slots, int j, int q) {
  const u64* p = slots + (std::size_t(j) * All + q) * kShards * kShardStride;
  u64 s = 0;
#pragma unroll
  for (int h = 0; h < kShards; ++h) s += __ldcg(p + h * kShardStride);
  return s;
}

// Whether the launch belongs to an attempt decided on the device whose gate is closed (Problem::gate).
template <class R>
__device__ bool gate_closed(const Problem<R>& p) {
  return p.gate && *static_cast<const volatile unsigned*>(p.gate) != 0;
}

// What a launch whose gate is closed reports (one gather that found nothing, no move: the host
// replays it as such); one block of the launch calls it.
__device__ __forceinline__ void report_closed_gate(u64* result) {
  if (threadIdx.x < kCounters) result[threadIdx.x] = 0;
  if (threadIdx.x == 0) result[std::size_t(kDeviceBatch) * kCounters] = 1;
}

// The warp's sum of x, in every lane (all 32 call it). redux.sync adds 32-bit values in one
// instruction, so x goes in three slices of 21, 21 and 22 bits, whose 32-lane sums fit 32 bits,
// recombined modulo 2^64: the same u64 as any order of additions, from three independent
// instructions instead of a chain of five 64-bit shuffles and adds, which the iteration's sums
// waited on (bench/experiments/README.md, session 27).
__device__ u64 warp_sum(u64 x) {
  constexpr unsigned k21 = (1u << 21) - 1;
  const u64 lo = __reduce_add_sync(0xffffffffu, unsigned(x) & k21);
  const u64 mid = __reduce_add_sync(0xffffffffu, unsigned(x >> 21) & k21);
  const u64 hi = __reduce_add_sync(0xffffffffu, unsigned(x >> 42));
  return lo + (mid << 21) + (hi << 42);
}

// The block's sums of its threads' counters c[0 .. K): each warp's go to s_red[q][warp], and after
// a barrier thread q < K returns counter q's (the others 0). Every thread of the block calls it.
template <int K, int Warps>
__device__ u64 block_sum(const u64 (&c)[K], u64 (&s_red)[K][Warps]) {
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
#pragma unroll
  for (int q = 0; q < K; ++q) {
    const u64 s = warp_sum(c[q]);
    if (lane == 0) s_red[q][warp] = s;
  }
  __syncthreads();
  u64 s = 0;
  if (threadIdx.x < K) {
#pragma unroll
    for (int w = 0; w < Warps; ++w) s += s_red[threadIdx.x][w];
  }
  return s;
}

// Column threadIdx.x of the held rows of iterations [from, end) to result, from the run that row
// end − 1 is in (the kernel's keep_row / end_rows). Not inlined: it runs once a run of kRowsHeld
// iterations, and inlined it cost the wall kernels 12-24 bytes of spills (not inlined, none
// since session 29; ptxas, sm_90).
template <int Reported>
__device__ __noinline__ void store_held_rows(u64* result, const u64 (*rows)[Reported], int end) {
  for (int r = (end - 1) / kRowsHeld * kRowsHeld; r < end; ++r)
    result[std::size_t(r) * kCounters + threadIdx.x] = rows[r % kRowsHeld][threadIdx.x];
}

}  // namespace

}  // namespace ff::overlap
