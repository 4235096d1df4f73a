// CUDA loops of neighbors.delaunay (loops.h): one thread per vertex, each warp combining its
// lanes' results and one lane per warp combining them into the result word with an integer
// atomicMax (the same value for any order). Nothing is read back here: the search reads the
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
  combine_max(i < n ? f.template search<kBlock>(i, fast + threadIdx.x) : 0u, word);
}

unsigned grid_of(std::size_t n) { return unsigned((n + kBlock - 1) / kBlock); }

template <class R>
void cuda_gather(std::size_t n, const GatherRing<R>& f, std::uint32_t* words, CUstream_st* s) {
  if (n == 0) return;
  max_kernel<<<grid_of(n), kBlock, 0, s>>>(n, f, words);
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
