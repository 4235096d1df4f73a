#include <algorithm>
#include <atomic>

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/loop.cuh"
#include "core/backend/cuda/pdl.cuh"
#include "core/backend/cuda/per_device.cuh"
#include "stages/delaunay/detect_inversion/stage.h"

namespace ff::delaunay {

// MarkInversions at 6 blocks of 256 per SM (40 registers, no spills) instead of the default
// allocation's 48 registers and 5 blocks: one block more per SM, measured faster at 2^20
// (bench-abp on the H100, interleaved; 8 blocks spill and gain less; numbers in bench/README.md,
// "Numbers formerly in source comments").
constexpr int kMarkBlocks = 6;

namespace {

constexpr int kMarkThreads = 256;

// MarkInversions' loop: as many blocks as the GPU holds at once (kMarkBlocks a SM), each
// striding over the edges; with f.publish the last block to finish copies the counters to
// f.publish. Each block's thread 0 fences after the block's barrier (every update the block made
// is then ordered before its ticket, as cooperative groups' grid barrier does) and takes a
// ticket; the block holding the last ticket has seen every block's. Striding keeps that to one
// fence and ticket per resident block (a few hundred, not one per 256 edges, each of which would
// hold its block's slot for an L2 round trip or two after its edges are done).
template <class R>
__global__ void __launch_bounds__(kMarkThreads, kMarkBlocks) mark_kernel(std::size_t n, MarkInversions<R> f) {
  // Launched after the integrator programmatically (core/backend/cuda/pdl.cuh); Lawson's tail
  // kernel may be scheduled as soon as every block is here.
  wait_for_previous_kernel();
  allow_next_kernel();
  // Edge ids are ints (3N < 2^31, common/mesh.h): 32-bit indices, fewer registers.
  const unsigned stride = gridDim.x * kMarkThreads, end = unsigned(n);
  for (unsigned i = blockIdx.x * kMarkThreads + threadIdx.x; i < end; i += stride) f(i);
  if (!f.publish) return;
  __syncthreads();
  if (threadIdx.x != 0) return;
  __threadfence();
  if (atomicAdd(f.blocks_done, 1u) != gridDim.x - 1) return;
  __threadfence();
  // Every counter loaded (from L2: the other blocks' atomics are there, not in this SM's L1)
  // before any is published: the loads go out together. A volatile load per counter, each
  // stored before the next one was loaded, made this block's end a chain of twelve round trips
  // (~3.7 k cycles; bench/experiments/README.md, "Lawson's tail and detect's end", session 31).
  unsigned c[kInversionCounters];
  for (int k = 0; k < kInversionCounters; ++k) c[k] = __ldcg(f.counters + k);
  for (int k = 0; k < kInversionCounters; ++k) f.publish[k] = c[k];
  if (f.gate) {
    const bool open = device_decision_open(c, f.capacity);
    *f.candidate_count = open ? std::int32_t(c[kCandidateCount]) : 0;
    *f.gate = open ? 0u : 1u;
  }
  *f.blocks_done = 0;  // for the next launch
}

template <class R>
void mark_loop(std::size_t n, const MarkInversions<R>& f, CUstream_st* stream) {
  if (n == 0) return;
  static std::atomic<int> known_per_sm[64] = {};  // (the occupancy belongs to the device)
  const int per_sm = once_per_device(known_per_sm, [] {
    int b = 0;
    FF_CUDA_CHECK(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&b, mark_kernel<R>, kMarkThreads, 0),
                  "sizing delaunay.detect_inversion's marking");
    return b > 0 ? b : 1;
  });
  int device = 0, sms = 0;
  FF_CUDA_CHECK(cudaGetDevice(&device), "sizing delaunay.detect_inversion's marking");
  FF_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device),
                "sizing delaunay.detect_inversion's marking");
  const std::size_t blocks = (n + kMarkThreads - 1) / kMarkThreads;
  const unsigned grid = unsigned(std::min<std::size_t>(blocks, std::size_t(sms) * std::size_t(per_sm)));
  launch_after_previous("launching delaunay.detect_inversion's marking", mark_kernel<R>, dim3(grid), dim3(kMarkThreads),
                        stream, n, f);
}

}  // namespace

template <class R>
DetectInversionLoops<R> detect_inversion_loops(CudaExec) {
  return {&mark_loop<R>, &CudaExec::for_each<CheckInverted<R>>};
}
template DetectInversionLoops<float> detect_inversion_loops<float>(CudaExec);
template DetectInversionLoops<double> detect_inversion_loops<double>(CudaExec);

}  // namespace ff::delaunay
