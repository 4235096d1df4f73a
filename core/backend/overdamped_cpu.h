// The CPU loop of the overdamped integrators (core/physics/overdamped.h), host only: include from
// cpu.cpp. Particles go in fixed blocks of kLanes = 16 (block b is particles b·kLanes ...), whose
// Gaussians gaussian_pair_lanes draws together (vectorized), then F::move runs per particle.
// The last block is padded: its extra lanes draw numbers nobody uses. Every particle's noise is
// a function of its counter only and its lane is fixed, so results do not depend on the thread
// count or on how oneTBB splits the range. A functor with after_moves (core/physics/overdamped.h)
// gets each block after its moves (the overdamped integrators' non-finite check).
//
// In a build for x86-64-v3 (AVX2) the block loop is compiled a second time for x86-64-v4
// (AVX-512) and taken on a CPU that has it (core/backend/cpu_isa.h): the same bits, and
// Box–Muller's lanes ~17 % faster on an AMD EPYC (Zen 5) (bench/README.md).
#pragma once
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>

#include "core/backend/cpu_isa.h"
#include "core/backend/exec.h"
#include "core/physics/overdamped.h"

namespace ff {

namespace overdamped_cpu_detail {
constexpr std::size_t kLanes = 16;

// Lane blocks [b0, b1) of n particles: noise, moves, after_moves.
template <class F>
__attribute__((always_inline)) inline void blocks(const F& f, const NoiseCounter& c, std::size_t n, std::size_t b0,
                                                  std::size_t b1) {
  constexpr int P = F::kNoisePairs;
  // A private copy, as cpu_for_each makes: its members stay in registers across the position
  // writes, which the compiler must otherwise assume may change anything reachable through f.
  const F local = f;
  for (std::size_t b = b0; b < b1; ++b) {
    const std::size_t first = b * kLanes;
    double z[2 * P][kLanes];
    const std::size_t m = std::min(kLanes, n - first);
    if (c.id) {  // particles numbered by id (NoiseCounter::id): the lanes draw for those numbers
      std::uint32_t ids[kLanes] = {};  // the last block's extra lanes draw for particle 0, unused
      for (std::size_t l = 0; l < m; ++l) ids[l] = c.id[first + l];
      for (int j = 0; j < P; ++j)
        gaussian_pair_lanes_of<int(kLanes)>(c.key, ids, c.step, c.attempt, local.noise_pair(j), z[2 * j],
                                            z[2 * j + 1], c.tail);
    } else {
      for (int j = 0; j < P; ++j)
        gaussian_pair_lanes<int(kLanes)>(c.key, std::uint32_t(first), c.step, c.attempt, local.noise_pair(j),
                                         z[2 * j], z[2 * j + 1], c.tail);
    }
    for (std::size_t l = 0; l < m; ++l) {
      double zl[2 * P];
      for (int k = 0; k < 2 * P; ++k) zl[k] = z[k][l];
      local.move(first + l, zl);
    }
    if constexpr (HasAfterMoves<F>::value) local.after_moves(first, m);
  }
}

template <class F>
__attribute__((flatten)) void blocks_build_isa(const F& f, const NoiseCounter& c, std::size_t n, std::size_t b0,
                                               std::size_t b1) {
  blocks(f, c, n, b0, b1);
}

#if FF_CPU_V4_DISPATCH
template <class F>
FF_TARGET_X86_64_V4 __attribute__((flatten)) void blocks_v4(const F& f, const NoiseCounter& c, std::size_t n,
                                                                   std::size_t b0, std::size_t b1) {
  blocks(f, c, n, b0, b1);
}
#endif
}  // namespace overdamped_cpu_detail

// The loop with the x86-64-v4 blocks (v4: only where cpu_has_x86_64_v4()) or the build's own.
template <class F>
void cpu_overdamped_loop(std::size_t n, const F& f, bool v4) {
  using namespace overdamped_cpu_detail;
  constexpr std::size_t kGrain = 2048 / kLanes;  // lane blocks per task at least
  const NoiseCounter c = f.noise_counter();
  auto run = [&](std::size_t b0, std::size_t b1) {
#if FF_CPU_V4_DISPATCH
    if (v4) return blocks_v4(f, c, n, b0, b1);
#else
    (void)v4;
#endif
    blocks_build_isa(f, c, n, b0, b1);
  };
  const std::size_t blocks = (n + kLanes - 1) / kLanes;
  if (blocks <= kGrain) {
    run(0, blocks);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) { run(r.begin(), r.end()); });
}

template <class F>
void cpu_overdamped_for_each(std::size_t n, const F& f, CUstream_st* /*stream*/) {
  cpu_overdamped_loop(n, f, cpu_has_x86_64_v4());
}

}  // namespace ff
