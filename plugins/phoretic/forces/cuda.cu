// CUDA loops of phoretic.forces. Long range: all pairs in shared-memory tiles (the tiling of
// Nyland, Harris & Prins, GPU Gems 3 ch. 31, and of Carter et al. 2017 section 4.5, with the
// tile in shared memory instead of Carter's 3 warp shuffles per source). A block of kBlock
// threads owns kBlock * P targets, P per thread in registers (register blocking: each source
// read is used P times). Per tile the block stages kBlock sources as {x, y[, z], α} (one 16- or
// 32-byte load each, read back as a broadcast), then every thread adds them to its P targets.
// Each target adds its sources in ascending order, k = i included (it adds zero), exactly as
// LongRangeVelocity::operator() and the CPU loop do; the pair term is kernel.h's.
// The targets are the call's (all, or a rank's share in a team: first_target on); those past
// the end compute on zeros and store nothing; the last tile's loop stops at N.
// In float a pair costs 18 instructions (kernel.h: one compare per image, one MUFU.RSQ); the
// pairs per second measured on the H100 are in bench/README.md.
// Short range: the element loop over Verlet rows.
#include <type_traits>

#include "core/backend/cuda/loop.cuh"
#include "plugins/phoretic/forces/stage.h"

namespace ff::phoretic {

namespace {

constexpr int kBlock = 256;

// One staged source: position and α, one vector load from shared memory.
template <class R>
struct alignas(4 * sizeof(R)) Source {
  R v[4];  // x, y, z (unused in 2D), alpha in v[3]
};

template <class R, int D, int P>
__device__ __forceinline__ void add_source(const LongRangeVelocity<R, D>& f, const Source<R> src, R (&xi)[P][D],
                                           R (&acc)[P][D]) {
#pragma unroll
  for (int j = 0; j < P; ++j) f.add(acc[j], xi[j], src.v, src.v[3]);
}

template <class R, int D, int P>
__global__ void __launch_bounds__(kBlock) long_range_kernel(LongRangeVelocity<R, D> f) {
  __shared__ Source<R> tile[kBlock];
  const std::size_t n = f.n, end = f.end_target();
  const std::size_t first = f.first_target + std::size_t(blockIdx.x) * (kBlock * P) + threadIdx.x;  // targets first + j kBlock
  R xi[P][D], acc[P][D];
#pragma unroll
  for (int j = 0; j < P; ++j) {
    const std::size_t i = first + std::size_t(j) * kBlock;
#pragma unroll
    for (int c = 0; c < D; ++c) {
      xi[j][c] = i < end ? f.position[i * D + c] : R(0);
      acc[j][c] = R(0);
    }
  }
  for (std::size_t k0 = 0; k0 < n; k0 += kBlock) {
    const std::size_t k = k0 + threadIdx.x;
    Source<R> mine{};
    if (k < n) {
#pragma unroll
      for (int c = 0; c < D; ++c) mine.v[c] = f.position[k * D + c];
      mine.v[3] = f.alpha_of(k);
    }
    __syncthreads();  // the previous tile has been read by every thread
    tile[threadIdx.x] = mine;
    __syncthreads();
    if (n - k0 >= std::size_t(kBlock)) {
#pragma unroll 8
      for (int t = 0; t < kBlock; ++t) add_source(f, tile[t], xi, acc);
    } else {
      const int m = int(n - k0);
      for (int t = 0; t < m; ++t) add_source(f, tile[t], xi, acc);
    }
  }
#pragma unroll
  for (int j = 0; j < P; ++j) {
    const std::size_t i = first + std::size_t(j) * kBlock;
    if (i < end) f.store(i, acc[j]);
  }
}

template <class R, int D, int P>
void launch_long_range(const LongRangeVelocity<R, D>& f, CUstream_st* stream) {
  const unsigned grid = unsigned((f.end_target() - f.first_target + kBlock * P - 1) / (kBlock * P));
  long_range_kernel<R, D, P><<<grid, kBlock, 0, stream>>>(f);
  FF_CUDA_CHECK_LAUNCH("launching the long-range phoretic kernel");
}

std::size_t multiprocessors() {
  int device = 0, sms = 0;
  FF_CUDA_CHECK(cudaGetDevice(&device), "phoretic.forces: asking for the current device");
  FF_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device),
                "phoretic.forces: asking for the number of multiprocessors");
  return std::size_t(sms);
}

// Targets per thread (H100, 2D, N = 2^15..2^17; bench/README.md): in float, 4 is the fastest
// when its blocks keep at least 90 % of the multiprocessors busy over the waves of blocks
// (2^17: 128 blocks of 1024 targets on 132 multiprocessors), and 1 otherwise (at 2^16, 4 per
// thread would leave half of them idle). In double, 1 is the fastest at every size measured.
template <class R, int D>
void cuda_long_range(const LongRangeVelocity<R, D>& f, CUstream_st* stream) {
  if (f.end_target() <= f.first_target) return;
  if constexpr (std::is_same_v<R, float>) {
    // Chosen by the targets of this call (a rank's share in a team); the sum of each target is
    // the same for P = 1 and 4 (the same add() in the same order; tests/test_team.cpp compares
    // 2 and 4 GPUs, whose shares choose differently, with one).
    const std::size_t sms = multiprocessors(), targets = f.end_target() - f.first_target;
    const std::size_t blocks = (targets + 4 * kBlock - 1) / (4 * kBlock), waves = (blocks + sms - 1) / sms;
    if (10 * blocks >= 9 * waves * sms) return launch_long_range<R, D, 4>(f, stream);
  }
  launch_long_range<R, D, 1>(f, stream);
}

}  // namespace

template <class R>
ForcesLoops<R> forces_loops(CudaExec) {
  return {&cuda_long_range<R, 2>, &cuda_long_range<R, 3>, &cuda_for_each<ShortRangeVelocity<R, 2>>,
          &cuda_for_each<ShortRangeVelocity<R, 3>>};
}
template ForcesLoops<float> forces_loops<float>(CudaExec);
template ForcesLoops<double> forces_loops<double>(CudaExec);

}  // namespace ff::phoretic
