// CUDA loops of pair.lj (loops.h). EXPERIMENT: FF_LJ_VARIANT picks the loop while the variants
// are measured (1: thread per particle, read-only loads; 2: + packed position/diameter records;
// 3/4: packed, 4/8 lanes per particle, in-order sum; 5: packed records and the list in a
// space-filling-curve order of the particles, remade when the list is rebuilt).
#include <cub/device/device_radix_sort.cuh>
#include <cuda_runtime.h>

#include <algorithm>

#include <cstdint>

#include "core/backend/cuda/loop.cuh"
#include "plugins/pair/lj/loops.h"

#ifndef FF_LJ_VARIANT
#define FF_LJ_VARIANT 2
#endif

namespace ff::pair {

namespace {

constexpr int kBlock = 256;

unsigned blocks(std::size_t threads) { return unsigned((threads + kBlock - 1) / kBlock); }

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

// One record of 4 reals per particle: its D coordinates, zeros, and its diameter last.
template <class R, int D>
__global__ void pack_kernel(std::size_t n, const R* __restrict__ x, const R* __restrict__ diameter,
                            R* __restrict__ packed) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  R v[4] = {};
  for (int c = 0; c < D; ++c) v[c] = x[i * D + c];
  v[3] = diameter ? diameter[i] : R(0);
  store4(packed + 4 * i, v);
}

template <class R, int D>
__device__ inline void write_out(const LJForce<R, D>& f, std::size_t i, const R acc[D], R u, R w) {
  for (int c = 0; c < D; ++c) f.force[i * D + c] = acc[c];
  if (f.energy) {
    f.energy[i] = R(0.5) * u;
    f.virial[i] = R(0.5) * w;
  }
}

// Variant 1: the functor's loop with read-only loads, no packing.
template <class R, int D>
__global__ void __launch_bounds__(kBlock) ldg_kernel(std::size_t n, LJForce<R, D> f) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  R xi[D], acc[D] = {}, u = 0, w = 0;
  for (int c = 0; c < D; ++c) xi[c] = __ldg(f.position + i * D + c);
  const int ti = f.type ? __ldg(f.type + i) : 0;
  const R di = f.diameter ? __ldg(f.diameter + i) : R(0);
  const std::uint32_t cnt = __ldg(f.count + i);
  const std::uint32_t* row = f.list + i * f.capacity;
  for (std::uint32_t a = 0; a < cnt; ++a) {
    const std::uint32_t j = __ldg(row + a);
    R xj[D];
    for (int c = 0; c < D; ++c) xj[c] = __ldg(f.position + std::size_t(j) * D + c);
    f.add_pair(xi, xj, di, f.diameter ? __ldg(f.diameter + j) : R(0), f.type ? ti * kMaxTypes + __ldg(f.type + j) : 0,
               acc, u, w);
  }
  write_out(f, i, acc, u, w);
}

// Variant 2: thread per particle over the packed records.
template <class R, int D>
__global__ void __launch_bounds__(kBlock) packed_kernel(std::size_t n, LJForce<R, D> f, const R* __restrict__ packed) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  R own[4], acc[D] = {}, u = 0, w = 0;
  load4(packed + 4 * i, own);
  const int ti = f.type ? __ldg(f.type + i) : 0;
  const std::uint32_t cnt = __ldg(f.count + i);
  const std::uint32_t* row = f.list + i * f.capacity;
  for (std::uint32_t a = 0; a < cnt; ++a) {
    const std::uint32_t j = __ldg(row + a);
    R other[4];
    load4(packed + 4 * std::size_t(j), other);
    f.add_pair(own, other, own[3], other[3], f.type ? ti * kMaxTypes + __ldg(f.type + j) : 0, acc, u, w);
  }
  write_out(f, i, acc, u, w);
}

// Variants 3/4: W lanes per particle; lane k takes entries k, k + W, ... of the row, and every
// lane adds the W terms of each round in entry order, so the sum is the row's, term by term
// (a term of a pair beyond the cutoff, or past the row's end, is +0: adding it leaves the sum,
// which starts at +0 and so is never −0, unchanged).
template <class R, int D, int W>
__global__ void __launch_bounds__(kBlock) lanes_kernel(std::size_t n, LJForce<R, D> f, const R* __restrict__ packed) {
  const std::size_t t = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const std::size_t i = t / W;
  const int lane = int(threadIdx.x % W);
  const bool live = i < n;
  R own[4] = {}, acc[D] = {}, u = 0, w = 0;
  std::uint32_t cnt = 0;
  int ti = 0;
  if (live) {
    load4(packed + 4 * i, own);
    cnt = __ldg(f.count + i);
    ti = f.type ? __ldg(f.type + i) : 0;
  }
  const std::uint32_t most = __reduce_max_sync(0xffffffffu, cnt);
  const std::uint32_t* row = f.list + i * f.capacity;
  for (std::uint32_t base = 0; base < most; base += W) {
    const std::uint32_t a = base + std::uint32_t(lane);
    R tf[D] = {}, tu = 0, tw = 0;
    if (a < cnt) {
      const std::uint32_t j = __ldg(row + a);
      R other[4];
      load4(packed + 4 * std::size_t(j), other);
      f.add_pair(own, other, own[3], other[3], f.type ? ti * kMaxTypes + __ldg(f.type + j) : 0, tf, tu, tw);
    }
    for (int k = 0; k < W; ++k) {
      for (int c = 0; c < D; ++c) acc[c] += __shfl_sync(0xffffffffu, tf[c], k, W);
      if (f.energy) {
        u += __shfl_sync(0xffffffffu, tu, k, W);
        w += __shfl_sync(0xffffffffu, tw, k, W);
      }
    }
  }
  if (live && lane == 0) write_out(f, i, acc, u, w);
}



// Variant 5. The loop takes particles in Morton order of their positions when the list was
// built (2^10 cells per axis in 3D, 2^16 in 2D), so the records a warp gathers lie close
// together; the records and the list are kept in that order (rank: particle → slot).
__device__ inline std::uint32_t spread3(std::uint32_t v) {  // 10 bits → every third bit
  v &= 0x3ffu;
  v = (v | (v << 16)) & 0x030000ffu;
  v = (v | (v << 8)) & 0x0300f00fu;
  v = (v | (v << 4)) & 0x030c30c3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}
__device__ inline std::uint32_t spread2(std::uint32_t v) {  // 16 bits → every second bit
  v &= 0xffffu;
  v = (v | (v << 8)) & 0x00ff00ffu;
  v = (v | (v << 4)) & 0x0f0f0f0fu;
  v = (v | (v << 2)) & 0x33333333u;
  v = (v | (v << 1)) & 0x55555555u;
  return v;
}

template <class R, int D>
__global__ void key_kernel(std::size_t n, const R* __restrict__ x, PeriodicBox<R> box, std::uint32_t* key,
                           std::uint32_t* index) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  constexpr int bits = D == 3 ? 10 : 16;
  std::uint32_t k = 0;
  for (int c = 0; c < D; ++c) {
    R u = x[i * D + c] * box.inv_L[c];
    u -= floor(u);
    int q = int(u * R(1 << bits));
    q = q < 0 ? 0 : (q >= (1 << bits) ? (1 << bits) - 1 : q);
    k |= (D == 3 ? spread3(std::uint32_t(q)) : spread2(std::uint32_t(q))) << c;
  }
  key[i] = k;
  index[i] = std::uint32_t(i);
}

__global__ void rank_kernel(std::size_t n, const std::uint32_t* __restrict__ perm, std::uint32_t* __restrict__ rank) {
  const std::size_t p = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (p < n) rank[perm[p]] = std::uint32_t(p);
}

// Row of slot p = the row of particle perm[p], each entry j as rank[j], in the row's order.
__global__ void slots_kernel(std::size_t n, const std::uint32_t* __restrict__ perm, const std::uint32_t* __restrict__ rank,
                             const std::uint32_t* __restrict__ list, const std::uint32_t* __restrict__ count,
                             std::uint32_t capacity, std::uint32_t* __restrict__ slots,
                             std::uint32_t* __restrict__ slot_count) {
  const std::size_t p = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (p >= n) return;
  const std::size_t i = perm[p];
  const std::uint32_t c = min(count[i], capacity);
  for (std::uint32_t a = 0; a < c; ++a)
    slots[FF_LJ_VARIANT == 6 ? p * capacity + a : std::size_t(a) * n + p] = rank[list[i * capacity + a]];
  slot_count[p] = c;
}

template <class R, int D>
__global__ void scatter_pack_kernel(std::size_t n, const R* __restrict__ x, const R* __restrict__ diameter,
                                    const std::int32_t* __restrict__ type, const std::uint32_t* __restrict__ rank,
                                    R* __restrict__ packed, std::int32_t* __restrict__ type_out) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n) return;
  R v[4] = {};
  for (int c = 0; c < D; ++c) v[c] = x[i * D + c];
  v[3] = diameter ? diameter[i] : R(0);
  const std::size_t p = rank[i];
  store4(packed + 4 * p, v);
  if (type) type_out[p] = type[i];
}

template <class R, int D>
__global__ void __launch_bounds__(kBlock) sorted_kernel(std::size_t n, LJForce<R, D> f, const R* __restrict__ packed,
                                                        const std::int32_t* __restrict__ type,
                                                        const std::uint32_t* __restrict__ perm,
                                                        const std::uint32_t* __restrict__ slots,
                                                        const std::uint32_t* __restrict__ slot_count) {
  const std::size_t p = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (p >= n) return;
  R own[4], acc[D] = {}, u = 0, w = 0;
  load4(packed + 4 * p, own);
  const int ti = type ? type[p] : 0;
  const std::uint32_t cnt = slot_count[p];
  for (std::uint32_t a = 0; a < cnt; ++a) {
    const std::uint32_t q = slots[std::size_t(a) * n + p];
    R other[4];
    load4(packed + 4 * std::size_t(q), other);
    f.add_pair(own, other, own[3], other[3], type ? ti * kMaxTypes + __ldg(type + q) : 0, acc, u, w);
  }
  write_out(f, perm[p], acc, u, w);
}


// Variant 6: variant 5's order, W lanes per slot (rows of the order's list row-major).
template <class R, int D, int W>
__global__ void __launch_bounds__(kBlock) sorted_lanes_kernel(std::size_t n, LJForce<R, D> f,
                                                              const R* __restrict__ packed,
                                                              const std::int32_t* __restrict__ type,
                                                              const std::uint32_t* __restrict__ perm,
                                                              const std::uint32_t* __restrict__ slots,
                                                              const std::uint32_t* __restrict__ slot_count) {
  const std::size_t t = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const std::size_t p = t / W;
  const int lane = int(threadIdx.x % W);
  const bool live = p < n;
  R own[4] = {}, acc[D] = {}, u = 0, w = 0;
  std::uint32_t cnt = 0;
  int ti = 0;
  if (live) {
    load4(packed + 4 * p, own);
    cnt = slot_count[p];
    ti = type ? type[p] : 0;
  }
  const std::uint32_t most = __reduce_max_sync(0xffffffffu, cnt);
  const std::uint32_t* row = slots + p * f.capacity;
  for (std::uint32_t base = 0; base < most; base += W) {
    const std::uint32_t a = base + std::uint32_t(lane);
    R tf[D] = {}, tu = 0, tw = 0;
    if (a < cnt) {
      const std::uint32_t q = __ldg(row + a);
      R other[4];
      load4(packed + 4 * std::size_t(q), other);
      f.add_pair(own, other, own[3], other[3], type ? ti * kMaxTypes + __ldg(type + q) : 0, tf, tu, tw);
    }
    for (int k = 0; k < W; ++k) {
      for (int c = 0; c < D; ++c) acc[c] += __shfl_sync(0xffffffffu, tf[c], k, W);
      if (f.energy) {
        u += __shfl_sync(0xffffffffu, tu, k, W);
        w += __shfl_sync(0xffffffffu, tw, k, W);
      }
    }
  }
  if (live && lane == 0) write_out(f, perm[p], acc, u, w);
}

// Remakes the order and the list in it when the list was rebuilt (or resized, or restored).
template <class R, int D>
void make_order(std::size_t n, const LJForce<R, D>& f, LJScratch<R>& s, const ListStamp& stamp, CUstream_st* stream) {
  if (s.seen[0] == stamp.list && s.seen[1] == stamp.count && s.seen[2] == stamp.capacity && s.seen_n == n) return;
  std::uint32_t* key = s.key.get(n);
  std::uint32_t* key_sorted = s.key_sorted.get(n);
  std::uint32_t* index = s.index.get(n);
  std::uint32_t* perm = s.perm.get(n);
  std::uint32_t* rank = s.rank.get(n);
  key_kernel<R, D><<<blocks(n), kBlock, 0, stream>>>(n, f.position, f.box, key, index);
  FF_CUDA_CHECK_LAUNCH("launching pair.lj's order keys");
  std::size_t temp_bytes = 0;
  FF_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, temp_bytes, key, key_sorted, index, perm, int(n), 0, 32, stream),
                "sizing pair.lj's order sort");
  void* temp = s.temp.get(std::max<std::size_t>(temp_bytes, 1));
  FF_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp, temp_bytes, key, key_sorted, index, perm, int(n), 0, 32, stream),
                "sorting pair.lj's order");
  rank_kernel<<<blocks(n), kBlock, 0, stream>>>(n, perm, rank);
  FF_CUDA_CHECK_LAUNCH("launching pair.lj's order ranks");
  slots_kernel<<<blocks(n), kBlock, 0, stream>>>(n, perm, rank, f.list, f.count, f.capacity,
                                                 s.slots.get(std::max<std::size_t>(1, n * f.capacity)), s.slot_count.get(n));
  FF_CUDA_CHECK_LAUNCH("launching pair.lj's list in order");
  s.seen[0] = stamp.list;
  s.seen[1] = stamp.count;
  s.seen[2] = stamp.capacity;
  s.seen_n = n;
}

template <class R, int D>
void forces(std::size_t n, const LJForce<R, D>& f, LJScratch<R>& scratch, const ListStamp& stamp, CUstream_st* stream) {
  if (n == 0) return;
  (void)stamp;
#if FF_LJ_VARIANT == 5 || FF_LJ_VARIANT == 6
  make_order(n, f, scratch, stamp, stream);
  R* packed = scratch.packed.get(4 * n);
  std::int32_t* type = f.type ? scratch.type.get(n) : nullptr;
  scatter_pack_kernel<R, D><<<blocks(n), kBlock, 0, stream>>>(n, f.position, f.diameter, f.type, scratch.rank.get(n),
                                                             packed, type);
  FF_CUDA_CHECK_LAUNCH("launching pair.lj's packing");
#if FF_LJ_VARIANT == 5
  sorted_kernel<R, D><<<blocks(n), kBlock, 0, stream>>>(n, f, packed, type, scratch.perm.get(n), scratch.slots.get(n * f.capacity ? n * f.capacity : 1),
                                                       scratch.slot_count.get(n));
#else
  sorted_lanes_kernel<R, D, 4><<<blocks(4 * n), kBlock, 0, stream>>>(n, f, packed, type, scratch.perm.get(n),
                                                                   scratch.slots.get(n * f.capacity ? n * f.capacity : 1),
                                                                   scratch.slot_count.get(n));
#endif
#elif FF_LJ_VARIANT == 1
  (void)scratch;
  ldg_kernel<R, D><<<blocks(n), kBlock, 0, stream>>>(n, f);
#else
  R* packed = scratch.packed.get(4 * n);
  pack_kernel<R, D><<<blocks(n), kBlock, 0, stream>>>(n, f.position, f.diameter, packed);
  FF_CUDA_CHECK_LAUNCH("launching pair.lj's packing");
#if FF_LJ_VARIANT == 2
  packed_kernel<R, D><<<blocks(n), kBlock, 0, stream>>>(n, f, packed);
#elif FF_LJ_VARIANT == 3
  lanes_kernel<R, D, 4><<<blocks(4 * n), kBlock, 0, stream>>>(n, f, packed);
#else
  lanes_kernel<R, D, 8><<<blocks(8 * n), kBlock, 0, stream>>>(n, f, packed);
#endif
#endif
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
