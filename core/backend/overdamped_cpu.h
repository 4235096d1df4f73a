// The CPU loop of the overdamped integrators (core/physics/overdamped.h), host only: include from
// cpu.cpp. Particles go in fixed blocks of kLanes = 16 (block b is particles b·kLanes ...), whose
// Gaussians gaussian_pair_lanes draws together (vectorized), then F::move runs per particle.
// The last block is padded: its extra lanes draw numbers nobody uses. Every particle's noise is
// a function of its counter only and its lane is fixed, so results do not depend on the thread
// count or on how oneTBB splits the range. A functor with after_moves (core/physics/overdamped.h)
// gets each block after its moves (the overdamped integrators' non-finite check).
#pragma once
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

#include <algorithm>

#include "core/backend/exec.h"
#include "core/physics/overdamped.h"

namespace ff {

template <class F>
void cpu_overdamped_for_each(std::size_t n, const F& f, CUstream_st* /*stream*/) {
  constexpr std::size_t kLanes = 16;
  constexpr std::size_t kGrain = 2048 / kLanes;  // lane blocks per task at least
  constexpr int P = F::kNoisePairs;
  const NoiseCounter c = f.noise_counter();
  auto run = [&](std::size_t b0, std::size_t b1) {
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
  };
  const std::size_t blocks = (n + kLanes - 1) / kLanes;
  if (blocks <= kGrain) {
    run(0, blocks);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, kGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) { run(r.begin(), r.end()); });
}

}  // namespace ff
