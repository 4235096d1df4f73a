// The harmonic contact force between soft disks (2D) or spheres (3D), on particle i:
//
//   F_i = Σ_j k (σ_ij − r_ij) r̂_ij   over neighbors j with r_ij < σ_ij,   σ_ij = (σ_i + σ_j)/2,
//
// r_ij = |d|, d = minimum image of x_i − x_j, r̂_ij = d / r_ij. It is F_i = −∇_i U of the pair
// energy U(r) = k/2 (σ_ij − r)² for r < σ_ij, 0 beyond: a Hookean spring between overlapping
// surfaces (Durian's bubble model; soft spheres near jamming). Units: k in k_BT/length², F in k_BT/length.
// Overdamped, an overlap decays at the rate 2μk, so an explicit step is stable for μ k Δt < 1.
// Particle i sums its own row of the Verlet list in list order: the same terms in the same order
// on every backend; math::mul_rn keeps the products out of fused multiply-adds.
#pragma once
#include <cmath>

#include "stages/neighbors/pair_force.h"

namespace ff::harmonic {

template <class R, int D>
struct HarmonicForce {
  R k;                                // stiffness (k_BT/length²)
  neighbors::PairSystem<R, D> sys;    // positions, diameters, Verlet list, box, `force`

  FF_HD void operator()(std::size_t i) const {
    R f[D] = {};
    for (const std::size_t j : sys.neighbors(i)) {
      R d[D], r2 = 0;
      for (int c = 0; c < D; ++c) {
        d[c] = sys.box.min_image(sys.position[i * D + c] - sys.position[j * D + c], c);
        r2 += math::mul_rn(d[c], d[c]);
      }
      const R sigma = R(0.5) * (sys.diameter[i] + sys.diameter[j]);
      if (r2 >= sigma * sigma || r2 == R(0)) continue;  // apart (or coincident: no direction)
      const R r = std::sqrt(r2);
      const R magnitude = k * (sigma - r) / r;  // k (σ − r) / r, times d gives k (σ − r) r̂
      for (int c = 0; c < D; ++c) f[c] += math::mul_rn(magnitude, d[c]);
      sys.count_pair(i, j);
    }
    for (int c = 0; c < D; ++c) sys.force[i * D + c] = f[c];
  }
};

}  // namespace ff::harmonic
