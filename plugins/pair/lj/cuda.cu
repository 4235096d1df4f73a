// CUDA loops of pair.lj (loops.h): the functor's sum (kernel.h, LJForce::add_pair), one thread
// per particle in index order, over one record per particle instead of the position and
// diameter arrays.
//
// A neighbour's position (3 reals at j·D, which straddles 32-byte sectors for half of the j)
// and its diameter cost ~2.5 scattered sectors per list entry. Each step a first kernel copies
// position and diameter into one record of 4 reals per particle (D coordinates, zeros, the
// diameter last: 32 bytes in double, 16 in float, aligned), and the sum reads each neighbour as
// that record: one sector, and the sum asks for the next neighbour's record before it adds the
// current pair's terms, so that gather is in flight during the arithmetic. The terms and their
// order are the CPU's (the row, in list order), so the bits are too. Measured against the
// functor's own loop and the variants that lost (lanes per particle, a spatial order of the
// particles): bench/experiments/README.md.
#include <cuda_runtime.h>

#include <cstdint>

#include "core/backend/cuda/loop.cuh"
#include "plugins/pair/lj/loops.h"

namespace ff::pair {

namespace {

constexpr int kBlock = 256;

unsigned blocks(std::size_t n) { return unsigned((n + kBlock - 1) / kBlock); }

__device__ inline void load4(const double* p, double v[4]) {
  const double2 a = __ldg(reinterpret_cast<const double2*>(p));
  const double2 b = __ldg(reinterpret_cast<const double2*>(p) + 1);
  v[0] = a.x;
  v[1] = a.y;
  v[2] = b.x;
  v[3] = b.y;
}
__device__ inline void load4(const float* p, float v[4]) {
  const float4 a = __ldg(reinterpret_cast<const float4*>(p));
  v[0] = a.x;
  v[1] = a.y;
  v[2] = a.z;
  v[3] = a.w;
}
__device__ inline void store4(double* p, const double v[4]) {
  reinterpret_cast<double2*>(p)[0] = make_double2(v[0], v[1]);
  reinterpret_cast<double2*>(p)[1] = make_double2(v[2], v[3]);
}
__device__ inline void store4(float* p, const float v[4]) {
  *reinterpret_cast<float4*>(p) = make_float4(v[0], v[1], v[2], v[3]);
}

template <class R, int D>
__global__ void pack_kernel(std::size_t n, const R* __restrict__ x, const R* __restrict__ diameter,
                            R* __restrict__ record) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  R v[4] = {};
  for (int c = 0; c < D; ++c) v[c] = x[i * D + c];
  v[3] = diameter ? diameter[i] : R(0);
  store4(record + 4 * i, v);
}

// The sum reads its row one entry ahead: the next neighbour's record (an L2 gather, the loop's
// latency) is in flight while the current pair's terms are computed. The terms are added in
// row order as before. 4 blocks of kBlock threads per SM (at most 64 registers), as the plain
// loop had.
template <class R, int D, int N>
__global__ void __launch_bounds__(kBlock, 4)
    force_kernel(std::size_t n, LJForce<R, D> f, const R* __restrict__ record) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  R own[4], acc[D] = {}, u = 0, w = 0;
  load4(record + 4 * i, own);
  const int ti = f.type ? __ldg(f.type + i) : 0;
  const std::uint32_t cnt = __ldg(f.count + i);
  const std::uint32_t* row = f.list + i * f.capacity;
  std::uint32_t j = cnt ? __ldg(row) : 0;
  R next[4];
  if (cnt) load4(record + 4 * std::size_t(j), next);
  for (std::uint32_t a = 0; a < cnt; ++a) {
    R other[4];
    for (int c = 0; c < 4; ++c) other[c] = next[c];
    const std::uint32_t here = j;
    if (a + 1 < cnt) {
      j = __ldg(row + a + 1);
      load4(record + 4 * std::size_t(j), next);
    }
    f.template add_pair<N>(own, other, own[3], other[3], f.type ? ti * kMaxTypes + __ldg(f.type + here) : 0, acc, u, w);
  }
  for (int c = 0; c < D; ++c) f.force[i * D + c] = acc[c];
  if (f.energy) {
    f.energy[i] = R(0.5) * u;
    f.virial[i] = R(0.5) * w;
  }
}

template <class R, int D>
void forces(std::size_t n, std::size_t held, const LJForce<R, D>& f, LJScratch<R>& scratch, CUstream_st* stream) {
  if (n == 0) return;
  // Records of every particle a row may name (a decomposed team's ghosts too), rows of the first n.
  R* record = scratch.record.get(4 * held);
  pack_kernel<R, D><<<blocks(held), kBlock, 0, stream>>>(held, f.position, f.diameter, record);
  FF_CUDA_CHECK_LAUNCH("launching pair.lj's records");
  // The exponent as a template argument for the common 2n–n forms (kernel.h, add_pair).
  if (f.n == 18) force_kernel<R, D, 18><<<blocks(n), kBlock, 0, stream>>>(n, f, record);
  else if (f.n == 6) force_kernel<R, D, 6><<<blocks(n), kBlock, 0, stream>>>(n, f, record);
  else force_kernel<R, D, 0><<<blocks(n), kBlock, 0, stream>>>(n, f, record);
  FF_CUDA_CHECK_LAUNCH("launching pair.lj");
}

}  // namespace

template <class R>
LJLoops<R> lj_loops(CudaExec) {
  return {&forces<R, 2>, &forces<R, 3>};
}
template LJLoops<float> lj_loops<float>(CudaExec);
template LJLoops<double> lj_loops<double>(CudaExec);

}  // namespace ff::pair
