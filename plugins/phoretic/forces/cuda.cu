// CUDA loops of phoretic.forces. Long range: Carter et al. 2017, section 4.5 / Algorithm 3 —
// one thread per target; the warp walks the sources in tiles of 32: each lane loads one source
// from global memory (coalesced), then the 32 sources are broadcast lane by lane with
// __shfl_sync, so most reads come from registers. Lanes past N still take part in the shuffles
// (the whole warp must) but store nothing; sources past N are skipped. Sources are added in
// ascending order, k = i included (it adds zero), exactly as on the CPU.
// Short range: the element loop over Verlet rows.
#include "core/cuda/loop.cuh"
#include "plugins/phoretic/forces/cuda.cuh"

namespace ff::phoretic {

namespace {

constexpr int kWarp = 32;
constexpr int kBlock = 128;

template <class R, int D>
__global__ void __launch_bounds__(kBlock) long_range_kernel(LongRangeVelocity<R, D> f) {
  const std::size_t i = std::size_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const int lane = threadIdx.x & (kWarp - 1);
  const bool active = i < f.n;
  R xi[D], acc[D];
  for (int c = 0; c < D; ++c) {
    xi[c] = active ? f.position[i * D + c] : R(0);
    acc[c] = R(0);
  }
  for (std::size_t k0 = 0; k0 < f.n; k0 += kWarp) {
    const std::size_t mine = k0 + lane;
    R xk[D], ak = R(0);
    for (int c = 0; c < D; ++c) xk[c] = mine < f.n ? f.position[mine * D + c] : R(0);
    if (mine < f.n) ak = f.alpha_of(mine);
#pragma unroll 4
    for (int s = 0; s < kWarp; ++s) {
      R xs[D];
      for (int c = 0; c < D; ++c) xs[c] = __shfl_sync(0xffffffffu, xk[c], s);
      const R as = __shfl_sync(0xffffffffu, ak, s);
      if (k0 + s < f.n) f.add(acc, xi, xs, as);
    }
  }
  if (active) f.store(i, acc);
}

template <class R, int D>
void cuda_long_range(const LongRangeVelocity<R, D>& f, CUstream_st* stream) {
  if (f.n == 0) return;
  const unsigned grid = unsigned((f.n + kBlock - 1) / kBlock);
  long_range_kernel<R, D><<<grid, kBlock, 0, stream>>>(f);
  FF_CUDA_CHECK_LAUNCH("launching the long-range phoretic kernel");
}

}  // namespace

template <class R>
ForcesLoops<R> cuda_forces_loops() {
  return {&cuda_long_range<R, 2>, &cuda_long_range<R, 3>, &cuda_for_each<ShortRangeVelocity<R, 2>>,
          &cuda_for_each<ShortRangeVelocity<R, 3>>};
}
template ForcesLoops<float> cuda_forces_loops<float>();
template ForcesLoops<double> cuda_forces_loops<double>();

}  // namespace ff::phoretic
