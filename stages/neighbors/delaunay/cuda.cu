// CUDA loops of neighbors.delaunay (loops.h): one thread per vertex, each warp combining its
// lanes' results and one lane per warp combining them into the result word with an integer
// atomicMax (the same value for any order). The gather places a block's rows with one atomicAdd
// on the fill counter after a scan of its threads' row lengths. Nothing is read back here: the search reads the
// gather's word on the device, and the stage reads both words once after the search.
#include <cuda_runtime.h>

#include "core/backend/cuda/check.h"
#include "core/backend/cuda/loop.cuh"
#include "stages/neighbors/delaunay/loops.h"

namespace ff::neighbors {

namespace {

constexpr int kBlock = 128;

__device__ void combine_max(std::uint32_t v, std::uint32_t* word) {
  for (int o = 16; o > 0; o >>= 1) v = max(v, __shfl_down_sync(0xffffffffu, v, o));
  if ((threadIdx.x & 31) == 0 && v) atomicMax(word, v);
}

template <class F>
__global__ void __launch_bounds__(kBlock) max_kernel(std::size_t n, F f, std::uint32_t* word) {
  const std::size_t i = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  combine_max(i < n ? std::uint32_t(f(i)) : 0u, word);
}

// The visited search with its fast slots in shared memory: thread t's slot a at a·kBlock + t,
// so the 32 threads of a warp always touch 32 different banks.
template <class R>
__global__ void __launch_bounds__(kBlock) visited_kernel(std::size_t n, SearchVisited<R> f, std::uint32_t* word) {
  __shared__ std::uint32_t fast[kFastSlots * kBlock];
  const std::size_t i = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  // The warp's searching lanes (the last warp may have fewer), which meet after the search's loop.
  const std::uint32_t lanes = __ballot_sync(0xffffffffu, i < n);
  combine_max(i < n ? f.template search<kBlock>(i, fast + threadIdx.x, lanes) : 0u, word);
}

// Walk each vertex's ring, scan the block's row lengths, take the block's table space, write.
template <class R>
__global__ void __launch_bounds__(kBlock) gather_kernel(std::size_t n, GatherRing<R> f, std::uint32_t* words) {
  __shared__ std::uint32_t warp_sums[kBlock / 32];
  __shared__ std::uint32_t block_start;
  const std::size_t i = std::size_t(blockIdx.x) * kBlock + threadIdx.x;
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  HeldRing held;
  if (i < n) held = f.walk(i);
  const std::uint32_t slots = i < n ? ring_slots(held.degree) : 0u;
  std::uint32_t incl = slots;  // inclusive scan within the warp
  for (int o = 1; o < 32; o <<= 1) {
    const std::uint32_t v = __shfl_up_sync(0xffffffffu, incl, o);
    if (lane >= o) incl += v;
  }
  if (lane == 31) warp_sums[warp] = incl;
  __syncthreads();
  std::uint32_t before = 0, total = 0;
  for (int w = 0; w < kBlock / 32; ++w) {
    before += w < warp ? warp_sums[w] : 0u;
    total += warp_sums[w];
  }
  if (threadIdx.x == 0) block_start = atomicAdd(words + 2, total);
  __syncthreads();
  const std::uint32_t start = block_start + before + incl - slots;
  std::uint32_t bits = 0;
  if (i < n) {
    // The 64-bit test also catches a fill counter that wrapped (a corrupt mesh's huge rings).
    if (std::uint64_t(block_start) + total <= f.table_slots) f.write(i, start, held);
    else bits = kRingOverflow;
    bits |= f.move_bits(i);
  }
  combine_max(bits, words);
}

unsigned grid_of(std::size_t n) { return unsigned((n + kBlock - 1) / kBlock); }

template <class R>
void cuda_gather(std::size_t n, const GatherRing<R>& f, std::uint32_t* words, CUstream_st* s) {
  if (n == 0) return;
  gather_kernel<R><<<grid_of(n), kBlock, 0, s>>>(n, f, words);
  FF_CUDA_CHECK_LAUNCH("launching the ring gather (neighbors.delaunay)");
}

template <class R>
void cuda_visited(std::size_t n, const SearchVisited<R>& f, std::uint32_t* words, CUstream_st* s) {
  if (n == 0) return;
  visited_kernel<R><<<grid_of(n), kBlock, 0, s>>>(n, f, words + 1);
  FF_CUDA_CHECK_LAUNCH("launching the search (neighbors.delaunay, visited)");
}

template <class R>
void cuda_parent(std::size_t n, const SearchParent<R>& f, std::uint32_t* words, CUstream_st* s) {
  if (n == 0) return;
  max_kernel<<<grid_of(n), kBlock, 0, s>>>(n, f, words + 1);
  FF_CUDA_CHECK_LAUNCH("launching the search (neighbors.delaunay, parent)");
}

}  // namespace

template <class R>
DelaunayLoops<R> delaunay_loops(CudaExec) {
  return {&cuda_gather<R>, &cuda_visited<R>, &cuda_parent<R>};
}
template DelaunayLoops<float> delaunay_loops<float>(CudaExec);
template DelaunayLoops<double> delaunay_loops<double>(CudaExec);

}  // namespace ff::neighbors
