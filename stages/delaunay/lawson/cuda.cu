#include "core/backend/cuda/check.h"
#include "core/backend/cuda/loop.cuh"
#include "core/backend/cuda/pdl.cuh"
#include "stages/delaunay/lawson/stage.h"

namespace ff::delaunay {

namespace {

constexpr int kTailThreads = 1024;

// LawsonTail's rounds (kernel.h): the grid version's three passes, with block barriers between.
// The block counts in shared memory (the list lengths its appends claim, the flips, rounds and
// refusals), so an append waits for a shared atomic instead of an L2 round trip and a list's
// length is known after the barrier that ends its pass; the counts go to `counters` once, at
// the end (the same final values: sums, a minimum, and the last lengths). Three barriers a
// round: each pass needs every write of the one before.
template <class R>
__global__ void __launch_bounds__(kTailThreads) tail_kernel(LawsonTail<R> t) {
  __shared__ unsigned sc[kLawsonCounters];
  __shared__ unsigned s_first;
  // Launched programmatically (core/backend/cuda/pdl.cuh); the correction's kernel may be
  // scheduled from here on.
  wait_for_previous_kernel();
  allow_next_kernel();
  unsigned* c = t.counters;
  // The grid kernels' counts, to which the block's are added at the end: loaded now, with the
  // gate, so that the end only stores (nothing in this kernel writes c before its end).
  unsigned grid[kLawsonCounters];
  if (threadIdx.x == 0) {
    reset_lawson_counters(sc);
    for (int k = 0; k < kLawsonCounters; ++k) grid[k] = __ldcg(c + k);
    unsigned first = t.first_count;
    if (t.gate) {  // a device-decided attempt: nothing to test while the gate is closed
      // (both loaded before either is needed: one round trip)
      const unsigned closed = __ldcg(t.gate), count = unsigned(__ldcg(t.first_count_at));
      first = closed ? 0u : count;
      if (!first) reset_lawson_counters(t.first_reset_next);  // (else round 0's element 0 does)
    } else if (!first) {
      sc[kLawsonMarked] = grid[kLawsonMarked];  // the marks of round t.round: the grid's
    }
    s_first = first;
  }
  __syncthreads();
  const unsigned first = s_first;
  if (first) {  // round 0 in this block: the grid loop's MarkNonDelaunay, counting in sc
    MarkNonDelaunay<R> mark{t.mesh, t.pts, t.tol, t.first_list, nullptr, t.marked, t.round, t.marked_list, sc, first};
    mark.reset_next = t.first_reset_next;
    for (unsigned i = threadIdx.x; i < first; i += kTailThreads) mark(i);
    __syncthreads();
  }
  std::int32_t round = t.round;
  std::int64_t ran = 0;
  unsigned largest = 0;
  for (; ran < t.max_rounds; ++ran) {
    const unsigned marked = sc[kLawsonMarked];
    // Apply lists the next round's edges (no thread reads the count before apply's barrier).
    if (threadIdx.x == 0) sc[kLawsonQueued] = 0;
    if (marked == 0 || marked > t.max_marked) break;
    largest = max(largest, marked);
    const DecideMarked decide{t.mesh, t.marked, round, t.marked_list, t.go, sc};
    for (unsigned i = threadIdx.x; i < marked; i += kTailThreads) decide(i);
    __syncthreads();
    // Every thread holds `marked`: the next marks may be counted from 0 (after apply's barrier).
    if (threadIdx.x == 0) sc[kLawsonMarked] = 0;
    const ApplyMarked apply{t.mesh, t.marked_list, t.go, t.queued, round + 1, t.list, sc};
    for (unsigned i = threadIdx.x; i < marked; i += kTailThreads) apply(i);
    __syncthreads();
    ++round;
    const unsigned queued = sc[kLawsonQueued];
    const MarkNonDelaunay<R> mark{t.mesh, t.pts, t.tol, t.list, nullptr, t.marked, round, t.marked_list, sc, queued};
    for (unsigned i = threadIdx.x; i < queued; i += kTailThreads) mark(i);
    __syncthreads();
  }
  if (threadIdx.x == 0) {
    // The block's passes are done (the loop ends after a barrier): the step's final counts, to
    // the counters and, from registers, to the host's copy.
    unsigned f[kLawsonCounters];
    f[kLawsonMarked] = sc[kLawsonMarked];
    f[kLawsonQueued] = sc[kLawsonQueued];
    f[kLawsonFlips] = grid[kLawsonFlips] + sc[kLawsonFlips];
    f[kLawsonRounds] = grid[kLawsonRounds] + sc[kLawsonRounds];
    f[kLawsonTooLong] = grid[kLawsonTooLong] + sc[kLawsonTooLong];
    f[kLawsonTooLongAt] = min(grid[kLawsonTooLongAt], sc[kLawsonTooLongAt]);
    f[kLawsonTailRounds] = unsigned(ran);
    f[kLawsonTailLargest] = largest;
    static_assert(kLawsonCounters == 8, "every counter is set above");
    for (int k = 0; k < kLawsonCounters; ++k) c[k] = f[k];
    if (t.publish)
      for (int k = 0; k < kLawsonCounters; ++k) t.publish[k] = f[k];
  }
}

static_assert(kTailRound0 <= kTailThreads, "round 0 in the tail kernel is one pass of its block");
static_assert(kGatedCandidates <= kTailRound0, "a gated launch's round 0 is one pass of the tail kernel's block");

template <class R>
void tail(const LawsonTail<R>& t, CUstream_st* stream) {
  launch_after_previous("launching delaunay.lawson's tail rounds", tail_kernel<R>, dim3(1), dim3(kTailThreads), stream,
                        t);
}

}  // namespace

template <class R>
LawsonLoops<R> lawson_loops(CudaExec) {
  return {&CudaExec::for_each<MarkNonDelaunay<R>>, &CudaExec::for_each<DecideMarked>, &CudaExec::for_each<ApplyMarked>,
          &tail<R>};
}
template LawsonLoops<float> lawson_loops<float>(CudaExec);
template LawsonLoops<double> lawson_loops<double>(CudaExec);

}  // namespace ff::delaunay
