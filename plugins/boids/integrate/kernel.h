// One step of the boids (../shared/specs/seed-gaps.md P2): constant speed v0 along the heading u,
// which the steering F (boids.forces, from the state at the start of the step) turns.
//
// continuous (default): the flow  dx/dt = v0 u,  du/dt = P_⊥(u) F / τ  (P_⊥ projects out u's
//   component), i.e. the heading angle θ turns at the rate ω = (u × F)/τ = (u_x F_y − u_y F_x)/τ.
//   One explicit step of Δt: x += v0 Δt u,  u ← u rotated by ω Δt (exactly, by its sine and cosine),
//   then renormalised so rounding never accumulates. Halving Δt (a rollback) is a finer step of the
//   same flow, and the step converges as Δt → 0.
// discrete: the authors' map, one per step (their Δt is 1 step): w = u + F, u ← w/|w|, then
//   x += v0 Δt u with the new heading (their order; v0 Δt is their per-step MAX_VEL). With Δt = τ
//   it is close to the flow but not equal (it turns by atan(|P_⊥F|/(1 + F·u)), the flow by |P_⊥F|).
//
// The angle's sine and cosine are core/physics/math.h's (the same bits on both backends), taken of
// |ω Δt| with the sign put back after, so turning left and right are exact mirror images.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/base/hd.h"
#include "core/physics/box.h"
#include "core/physics/math.h"
#include "core/stage/step_params.h"

namespace ff::boids {

template <class R, bool Discrete>
struct BoidsStep {
  const R* steering;         // N x 2: F
  R* position;               // N x 2
  std::int32_t* image;       // N x 2
  R* heading;                // N x 2, unit vectors
  PeriodicBox<R> box;
  double v0;                 // speed (σ/τ)
  double inv_tau;            // 1/τ: the turning rate per unit steering (continuous)
  const StepParams* params;  // Δt, on the loop's side

  FF_HD void operator()(std::size_t i) const {
    const R dt = R(params->dt);
    const R ux = heading[2 * i], uy = heading[2 * i + 1];
    const R fx = steering[2 * i], fy = steering[2 * i + 1];
    R nx, ny;  // the new heading, before normalising
    R vx, vy;  // the heading the boid flies along in this step
    if constexpr (Discrete) {
      nx = ux + fx;
      ny = uy + fy;
      vx = nx;
      vy = ny;
    } else {
      const double angle = double(math::mul_rn(ux, fy) - math::mul_rn(uy, fx)) * inv_tau * double(dt);  // ω Δt
      double s, c;
      math::sincos(std::fabs(angle), s, c);
      const R sn = R(angle < 0 ? -s : s), cs = R(c);
      // Two sums, not a difference and a sum: GCC 12 vectorizes (a·b − c·d, e·f + g·h) into one
      // fused vfmaddsub even with -ffp-contract=off, which would change the CPU's bits.
      nx = math::mul_rn(cs, ux) + math::mul_rn(-sn, uy);
      ny = math::mul_rn(sn, ux) + math::mul_rn(cs, uy);
      vx = ux;
      vy = uy;
    }
    const R norm = std::sqrt(math::mul_rn(nx, nx) + math::mul_rn(ny, ny));
    if (norm > R(0)) {  // a discrete w = 0 (steering exactly against the heading) keeps u
      nx /= norm;
      ny /= norm;
      if constexpr (Discrete) {
        vx = nx;
        vy = ny;
      }
      heading[2 * i] = nx;
      heading[2 * i + 1] = ny;
    } else {
      vx = ux;
      vy = uy;
    }
    const R step = R(v0 * double(dt));
    R x = position[2 * i] + math::mul_rn(step, vx);
    R y = position[2 * i + 1] + math::mul_rn(step, vy);
    int ix = image[2 * i], iy = image[2 * i + 1];
    box.wrap(x, ix, 0);
    box.wrap(y, iy, 1);
    position[2 * i] = x;
    position[2 * i + 1] = y;
    image[2 * i] = ix;
    image[2 * i + 1] = iy;
  }
};

}  // namespace ff::boids
