// An external harmonic potential, an optical trap, on particle i:
//
//   U_i = k/2 Σ_a m_a d_a²,   F_i = −∇_i U_i:  F_a = −k m_a d_a,   d = minimum image of x_i − c(t),
//
// c(t) = c + v t the trap's centre (v = 0: fixed; t the step's start time, so a moving trap is an
// explicit step like the force itself), m_a = 1 on the trapped axes and 0 on the others (all of
// them by default); only the particles of the trapped types feel it (all by default: a probe of
// one type dragged through a bath of another is active microrheology). Units: k in
// k_BT/length², F in k_BT/length, U in k_BT, v in lengths per unit time. Overdamped
// (x += μ F Δt + noise) a particle relaxes to c at the rate μk, so an explicit step is stable for
// μ k Δt < 2; in equilibrium ⟨d_a²⟩ = k_BT/k per trapped axis (k_BT = D/μ), and behind a trap
// moving at v it lags by ⟨d⟩ = −v/(μk) (Stokes drag: the trap pulls with k v/(μk) = v/μ; exact in
// Euler–Maruyama too). Every particle feels its own trap, independently of the others, and writes
// only its own entries. math::mul_rn keeps the products out of fused multiply-adds: the same bits
// on the CPU and the GPU. nvcc-clean.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "core/physics/math.h"
#include "core/stage/step_params.h"

namespace ff::trap {

template <class R, int D>
struct TrapForce {
  const R* position;           // N x D
  R* force;                    // N x D: written, or added to (add)
  R* energy;                   // N: U_i, or null (no energy field)
  const std::int32_t* type;    // N, or null: every particle is trapped
  std::uint32_t trapped_types; // with type: bit t set when particles of type t feel the trap
  PeriodicBox<R> box;
  R k;                         // stiffness (k_BT/length²)
  double centre[D];            // c at t = 0 (box units)
  double velocity[D];          // v (box units per unit time), with params
  double length[D];            // the box's edges, in double for the moving centre's wrap
  R mask[D];                   // 1: the axis is trapped; 0: free
  bool add;                    // add F_i to the force an earlier stage wrote this step
  const StepParams* params;    // the step's start time for a moving trap; null: the trap is fixed

  // c_a(t), wrapped into [0, L_a): formed in double, then rounded to R once (a fixed trap: R(c_a)).
  FF_HD R centre_at(int a) const {
    if (!params) return R(centre[a]);
    const double L = length[a];
    double c = centre[a] + math::mul_rn(velocity[a], params->time);
    c -= math::mul_rn(L, std::floor(c / L));
    return R(c);
  }

  FF_HD void operator()(std::size_t i) const {
    const bool trapped = !type || ((trapped_types >> type[i]) & 1u);
    R d2 = 0;
    for (int a = 0; a < D; ++a) {
      const R d = trapped ? math::mul_rn(mask[a], box.min_image(position[i * D + a] - centre_at(a), a)) : R(0);
      const R f = trapped ? -math::mul_rn(k, d) : R(0);
      force[i * D + a] = add ? force[i * D + a] + f : f;
      d2 += math::mul_rn(d, d);
    }
    if (energy) energy[i] = math::mul_rn(R(0.5) * k, d2);
  }
};

}  // namespace ff::trap
