// Harmonic contact forces between soft disks (2D) or spheres (3D), per particle i:
//
//   F_i = Σ_j k (σ_ij − r_ij) r̂_ij   over neighbours j with r_ij < σ_ij,   σ_ij = (σ_i + σ_j)/2,
//
// r_ij = |d|, d = minimum image of x_i − x_j, r̂_ij = d / r_ij. It is F_i = −∇_i U of the pair
// energy U(r) = k/2 (σ_ij − r)² for r < σ_ij, 0 beyond: a Hookean spring between overlapping
// surfaces (Durian's bubble model; soft spheres near jamming). Units: k in k_BT/σ², F in k_BT/σ.
// Overdamped, an overlap decays at the rate 2μk, so an explicit step is stable for μ k Δt < 1
// (pipelines/harmonic.yaml: 1 · 100 · 0.001 = 0.1). Each particle sums its own
// Verlet row in list order (ascending j), so the sum is the same on every backend: the products
// that feed a sum are math::mul_rn (never fused into an fma). nvcc-clean.
#pragma once
#include <cmath>
#include <cstdint>

#include "core/backend/atomics.h"
#include "core/physics/box.h"
#include "core/base/hd.h"
#include "core/physics/math.h"

namespace ff::harmonic {

template <class R, int D>
struct PairForce {
  const R* position;          // N x D
  const R* diameter;          // N
  R* force;                   // N x D (written)
  const std::uint32_t* list;  // N x capacity: row i = neighbours of i, ascending
  const std::uint32_t* count; // N: entries set in row i
  std::uint32_t capacity;
  PeriodicBox<R> box;
  R k;                        // stiffness (k_BT/σ²)
  unsigned* pairs;            // overlapping pairs j > i are counted here

  FF_HD void operator()(std::size_t i) const {
    R f[D] = {};
    for (std::uint32_t a = 0; a < count[i]; ++a) {
      const std::uint32_t j = list[i * capacity + a];
      R d[D], r2 = 0;
      for (int c = 0; c < D; ++c) {
        d[c] = box.min_image(position[i * D + c] - position[std::size_t(j) * D + c], c);
        r2 += math::mul_rn(d[c], d[c]);
      }
      const R sigma = R(0.5) * (diameter[i] + diameter[j]);
      if (r2 >= sigma * sigma || r2 == R(0)) continue;  // apart (or coincident: no direction)
      const R r = std::sqrt(r2);
      const R magnitude = k * (sigma - r) / r;  // k (σ − r) / r, times d gives k (σ − r) r̂
      for (int c = 0; c < D; ++c) f[c] += math::mul_rn(magnitude, d[c]);
      if (j > i) count_one(pairs);
    }
    for (int c = 0; c < D; ++c) force[i * D + c] = f[c];
  }
};

}  // namespace ff::harmonic
