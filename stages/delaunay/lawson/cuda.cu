#include <cooperative_groups.h>

#include <atomic>

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/cluster.cuh"
#include "core/backend/cuda/loop.cuh"
#include "core/backend/cuda/pdl.cuh"
#include "core/backend/cuda/per_device.cuh"
#include "stages/delaunay/lawson/stage.h"

namespace ff::delaunay {

namespace {

namespace cg = cooperative_groups;

constexpr int kTailThreads = 1024;

// The tail's rounds on a thread-block cluster of kTailCluster blocks (sm_90; 16 is above the
// portable size of 8) where the mesh has at least kTailClusterEdges edges; one block below. A
// flip writes 14 scattered words (in 10 stores: mesh.h's flip_edge), and one SM queues them: at
// N = 2^14 (~290 flips a round) one flip's 14 stores took 2.8-4.8 k cycles and the vertex-edge
// loads behind them (now before them) 2.5-5 k, against 0.1 k and 0.4 k with 18 flips at 2^10
// (clock64, session 31, bench/experiments/README.md, "Lawson's tail and detect's end"). A
// cluster spreads a pass's elements over 16 SMs, for barriers that cost more than a block's: it
// tied one block at 2^14, lost 3.7 % at 2^13 and gained 4.7 / 9.2 / 6.1 % at 2^15 / 2^16 / 2^17
// (bench-abp, device-decided steps included); clusters of 4 or 8 from 8 192 particles lost
// 0.7-3 % at 2^13-2^15 (bench/experiments/README.md, "Lawson's tail at its edges").
constexpr int kTailCluster = 16;
constexpr std::size_t kTailClusterEdges = 3 * 32768;

// A barrier among the tail's blocks that orders global and shared memory: the block's, or the
// cluster's (a release and an acquire at cluster scope).
template <int Blocks>
__device__ __forceinline__ void tail_sync() {
  if constexpr (Blocks == 1) {
    __syncthreads();
  } else {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
    cg::this_cluster().sync();
#else
    __trap();  // never launched: tail() launches clusters only on devices that have them
#endif
  }
}

// p (in this block's shared memory) in block 0's shared memory: itself in one block, else through
// the cluster's distributed shared memory.
template <int Blocks, class T>
__device__ __forceinline__ T* in_block0(T* p) {
  if constexpr (Blocks == 1) {
    return p;
  } else {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
    return cg::this_cluster().map_shared_rank(p, 0);
#else
    __trap();
    return p;
#endif
  }
}

// This block's rank in the tail's cluster (0 in one block).
template <int Blocks>
__device__ __forceinline__ unsigned tail_rank() {
  if constexpr (Blocks == 1) {
    return 0;
  } else {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
    return cg::this_cluster().block_rank();
#else
    return 0;
#endif
  }
}

// LawsonTail's rounds (kernel.h): the grid version's three passes, with barriers between, in one
// block or a cluster of Blocks blocks (each thread takes every Blocks·kTailThreads-th element).
// Block 0 counts in its shared memory (the list lengths the appends claim, the flips, rounds and
// refusals; the cluster's other blocks through distributed shared memory), so an append waits for
// a shared atomic instead of an L2 round trip and a list's length is known after the barrier that
// ends its pass; the counts go to `counters` once, at the end (the same final values: sums, a
// minimum, and the last lengths). Three barriers a round: each pass needs every write of the one
// before. Who tests, decides or flips an edge does not change the flips (kernel.h), so one block
// and a cluster give the same triangulation.
template <class R, int Blocks>
__global__ void __launch_bounds__(kTailThreads) tail_kernel(LawsonTail<R> t) {
  __shared__ unsigned s_counts[kLawsonCounters];
  __shared__ unsigned s_first;
  // Launched programmatically (core/backend/cuda/pdl.cuh); the correction's kernel may be
  // scheduled from here on.
  wait_for_previous_kernel();
  allow_next_kernel();
  const unsigned rank = tail_rank<Blocks>();
  const bool lead = rank == 0 && threadIdx.x == 0;  // the thread that sets up and ends
  unsigned* c = t.counters;
  // The grid kernels' counts, to which the tail's are added at the end: loaded now, with the
  // gate, so that the end only stores (nothing in this kernel writes c before its end).
  unsigned grid[kLawsonCounters];
  if (lead) {
    reset_lawson_counters(s_counts);
    for (int k = 0; k < kLawsonCounters; ++k) grid[k] = __ldcg(c + k);
    unsigned first = t.first_count;
    if (t.gate) {  // a device-decided attempt: nothing to test while the gate is closed
      // (both loaded before either is needed: one round trip)
      const unsigned closed = __ldcg(t.gate), count = unsigned(__ldcg(t.first_count_at));
      first = closed ? 0u : count;
      if (!first) reset_lawson_counters(t.first_reset_next);  // (else round 0's element 0 does)
    } else if (!first) {
      s_counts[kLawsonMarked] = grid[kLawsonMarked];  // the marks of round t.round: the grid's
    }
    s_first = first;
  }
  // (in a cluster also: every block has started, so block 0's shared memory may be used)
  tail_sync<Blocks>();
  unsigned* sc = in_block0<Blocks>(s_counts);
  const unsigned first = *in_block0<Blocks>(&s_first);
  // Consecutive elements go to the cluster's blocks in turn: a pass of a few hundred elements is
  // spread over every SM (blocks taking consecutive ranges left every pass of fewer than 1 024
  // elements to block 0, and gained nothing: bench/experiments/README.md).
  const unsigned tid = threadIdx.x * Blocks + rank;
  constexpr unsigned kStride = Blocks * kTailThreads;
  if (first) {  // round 0 here: the grid loop's MarkNonDelaunay, counting in sc
    MarkNonDelaunay<R> mark{t.mesh, t.pts, t.tol, t.first_list, nullptr, t.marked, t.round, t.marked_list, sc, first};
    mark.reset_next = t.first_reset_next;
    for (unsigned i = tid; i < first; i += kStride) mark(i);
    tail_sync<Blocks>();
  }
  std::int32_t round = t.round;
  std::int64_t ran = 0;
  unsigned largest = 0;
  for (; ran < t.max_rounds; ++ran) {
    const unsigned marked = sc[kLawsonMarked];
    // Apply lists the next round's edges (no thread reads the count before apply's barrier).
    if (lead) sc[kLawsonQueued] = 0;
    if (marked == 0 || marked > t.max_marked) break;
    largest = max(largest, marked);
    const DecideMarked decide{t.mesh, t.marked, round, t.marked_list, t.go, sc};
    for (unsigned i = tid; i < marked; i += kStride) decide(i);
    tail_sync<Blocks>();
    // Every thread holds `marked`: the next marks may be counted from 0 (after apply's barrier).
    if (lead) sc[kLawsonMarked] = 0;
    const ApplyMarked apply{t.mesh, t.marked_list, t.go, t.queued, round + 1, t.list, sc};
    for (unsigned i = tid; i < marked; i += kStride) apply(i);
    tail_sync<Blocks>();
    ++round;
    const unsigned queued = sc[kLawsonQueued];
    const MarkNonDelaunay<R> mark{t.mesh, t.pts, t.tol, t.list, nullptr, t.marked, round, t.marked_list, sc, queued};
    for (unsigned i = tid; i < queued; i += kStride) mark(i);
    tail_sync<Blocks>();
  }
  // A cluster's blocks read block 0's counts at the loop's head: block 0 keeps its shared memory
  // until all have.
  if constexpr (Blocks > 1) tail_sync<Blocks>();
  if (lead) {
    // Every pass is done (the loop ends after a barrier): the step's final counts, to the
    // counters and, from registers, to the host's copy.
    unsigned f[kLawsonCounters];
    f[kLawsonMarked] = s_counts[kLawsonMarked];
    f[kLawsonQueued] = s_counts[kLawsonQueued];
    f[kLawsonFlips] = grid[kLawsonFlips] + s_counts[kLawsonFlips];
    f[kLawsonRounds] = grid[kLawsonRounds] + s_counts[kLawsonRounds];
    f[kLawsonTooLong] = grid[kLawsonTooLong] + s_counts[kLawsonTooLong];
    f[kLawsonTooLongAt] = min(grid[kLawsonTooLongAt], s_counts[kLawsonTooLongAt]);
    f[kLawsonTailRounds] = unsigned(ran);
    f[kLawsonTailLargest] = largest;
    static_assert(kLawsonCounters == 8, "every counter is set above");
    for (int k = 0; k < kLawsonCounters; ++k) c[k] = f[k];
    if (t.publish)
      for (int k = 0; k < kLawsonCounters; ++k) t.publish[k] = f[k];
  }
}

// Whether the current device runs the tail's cluster; asked once a precision and device.
template <class R>
bool tail_cluster_fits() {
  static std::atomic<int> known[64] = {};
  // (cluster_fits also allows the kernel the non-portable cluster size, on the current device.)
  return once_per_device(known, [] {
           return int(cluster_fits(reinterpret_cast<const void*>(tail_kernel<R, kTailCluster>), kTailCluster,
                                   kTailThreads, 0, "delaunay.lawson: the tail's cluster"));
         }) != 0;
}

// Whether the tail's rounds on a mesh of so many edges run on the cluster.
template <class R>
bool tail_on_cluster(std::size_t edges) {
  return edges >= kTailClusterEdges && tail_cluster_fits<R>();
}

template <class R>
void tail(const LawsonTail<R>& t, CUstream_st* stream) {
  if (tail_on_cluster<R>(t.edges)) {
    cudaLaunchAttribute attr[2];
    cudaLaunchConfig_t cfg = cluster_config(kTailCluster, kTailThreads, stream, attr);
    cfg.numAttrs = programmatic_attr(attr, cfg.numAttrs);
    const char* what = "launching delaunay.lawson's tail rounds (a cluster)";
    FF_CUDA_CHECK(cudaLaunchKernelEx(&cfg, tail_kernel<R, kTailCluster>, t), what);
    FF_CUDA_CHECK_LAUNCH(what);
    return;
  }
  launch_after_previous("launching delaunay.lawson's tail rounds", tail_kernel<R, 1>, dim3(1), dim3(kTailThreads),
                        stream, t);
}

// One pass of the tail kernel's threads on a mesh of so many edges (LawsonLoops::tail_pass).
template <class R>
unsigned tail_pass(std::size_t edges) {
  return unsigned(tail_on_cluster<R>(edges) ? kTailCluster * kTailThreads : kTailThreads);
}

// A grid round's passes (mark, decide, apply: one element a thread), each launched after the
// kernel before it (core/backend/cuda/loop.cuh), so that it is scheduled while that kernel runs
// (a large step's rounds: three kernels a round).
template <class F>
void round_pass(std::size_t n, const F& f, CUstream_st* stream) {
  cuda_for_each_after_previous("launching a delaunay.lawson round's pass", n, f, stream);
}

}  // namespace

template <class R>
LawsonLoops<R> lawson_loops(CudaExec) {
  return {&round_pass<MarkNonDelaunay<R>>, &round_pass<DecideMarked>, &round_pass<ApplyMarked>, &tail<R>,
          &tail_pass<R>};
}
template LawsonLoops<float> lawson_loops<float>(CudaExec);
template LawsonLoops<double> lawson_loops<double>(CudaExec);

}  // namespace ff::delaunay
