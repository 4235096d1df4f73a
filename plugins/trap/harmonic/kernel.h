// An external harmonic potential, an optical trap, on particle i:
//
//   U_i = k/2 Σ_a m_a d_a²,   F_i = −∇_i U_i:  F_a = −k m_a d_a,   d = minimum image of x_i − c,
//
// c the trap's centre, m_a = 1 on the trapped axes and 0 on the others (all of them by default).
// Units: k in k_BT/length², F in k_BT/length, U in k_BT. Overdamped (x += μ F Δt + noise) a
// particle relaxes to c at the rate μk, so an explicit step is stable for μ k Δt < 2; in
// equilibrium ⟨d_a²⟩ = k_BT/k per trapped axis (k_BT = D/μ). Every particle feels its own trap,
// independently of the others, and writes only its own entries. math::mul_rn keeps the products
// out of fused multiply-adds: the same bits on the CPU and the GPU. nvcc-clean.
#pragma once
#include <cstddef>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "core/physics/math.h"

namespace ff::trap {

template <class R, int D>
struct TrapForce {
  const R* position;  // N x D
  R* force;           // N x D: written, or added to (add)
  R* energy;          // N: U_i, or null (no energy field)
  PeriodicBox<R> box;
  R k;                // stiffness (k_BT/length²)
  R centre[D];        // c (box units)
  R mask[D];          // 1: the axis is trapped; 0: free
  bool add;           // add F_i to the force an earlier stage wrote this step

  FF_HD void operator()(std::size_t i) const {
    R d2 = 0;
    for (int a = 0; a < D; ++a) {
      const R d = math::mul_rn(mask[a], box.min_image(position[i * D + a] - centre[a], a));
      const R f = -math::mul_rn(k, d);
      force[i * D + a] = add ? force[i * D + a] + f : f;
      d2 += math::mul_rn(d, d);
    }
    if (energy) energy[i] = math::mul_rn(R(0.5) * k, d2);
  }
};

}  // namespace ff::trap
