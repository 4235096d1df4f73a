#include "core/backend/cuda/check.h"
#include "core/backend/cuda/loop.cuh"
#include "stages/delaunay/lawson/stage.h"

namespace ff::delaunay {

namespace {

constexpr int kTailThreads = 1024;

// A counter that this block's atomics (in L2) changed: read past L1.
__device__ unsigned counter(const unsigned* p) { return *static_cast<const volatile unsigned*>(p); }

// LawsonTail's rounds (kernel.h): the grid version's three passes, with block barriers between.
template <class R>
__global__ void __launch_bounds__(kTailThreads) tail_kernel(LawsonTail<R> t) {
  __shared__ unsigned s_len;
  unsigned* c = t.counters;
  std::int32_t round = t.round;
  std::int64_t ran = 0;
  unsigned largest = 0;
  for (; ran < t.max_rounds; ++ran) {
    if (threadIdx.x == 0) {
      s_len = counter(c + kLawsonMarked);
      c[kLawsonQueued] = 0;  // apply lists the next round's edges
    }
    __syncthreads();
    const unsigned marked = s_len;
    if (marked == 0 || marked > t.max_marked) break;
    largest = max(largest, marked);
    const DecideMarked decide{t.mesh, t.marked, round, t.marked_list, t.go, c};
    for (unsigned i = threadIdx.x; i < marked; i += kTailThreads) decide(i);
    __syncthreads();
    const ApplyMarked apply{t.mesh, t.marked_list, t.go, t.queued, round + 1, t.list, c};
    for (unsigned i = threadIdx.x; i < marked; i += kTailThreads) apply(i);
    __syncthreads();
    if (threadIdx.x == 0) {
      s_len = counter(c + kLawsonQueued);
      c[kLawsonMarked] = 0;
    }
    __syncthreads();
    ++round;
    const unsigned queued = s_len;
    const MarkNonDelaunay<R> mark{t.mesh, t.pts, t.tol, t.list, nullptr, t.marked, round, t.marked_list, c, queued};
    for (unsigned i = threadIdx.x; i < queued; i += kTailThreads) mark(i);
    __syncthreads();
  }
  if (threadIdx.x == 0) {
    c[kLawsonTailRounds] = unsigned(ran);
    c[kLawsonTailLargest] = largest;
    // The block's atomics are done (the loop ends after a barrier) and the grid kernels before
    // it finished: these are the step's final counts.
    if (t.publish)
      for (int k = 0; k < kLawsonCounters; ++k) t.publish[k] = counter(c + k);
  }
}

template <class R>
void tail(const LawsonTail<R>& t, CUstream_st* stream) {
  tail_kernel<R><<<1, kTailThreads, 0, stream>>>(t);
  FF_CUDA_CHECK_LAUNCH("launching delaunay.lawson's tail rounds");
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
