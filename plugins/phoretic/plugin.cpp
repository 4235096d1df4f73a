// The phoretic model plugin: self-diffusiophoretic colloids with per-type charges α (emits the
// field) and μ (responds to it), non-reciprocal pair velocities v_i = Σ_k μ_i α_k f(r_i - r_k)
// (Carter et al. 2017, eq. 2-3), integrated by Euler–Maruyama (eq. 1).
//
// Two stages rather than one fused kernel: phoretic.forces writes the pair velocity into the
// `velocity` field, phoretic.integrate moves the particles. The pair sum has two very different
// loop shapes (all pairs in shared-memory tiles, or Verlet rows) while the update is one elementwise
// step; keeping them apart writes the update once, lets other velocity sources feed the same
// integrator, and makes `velocity` an observable. The price is one extra read and write of
// N·d reals per step, small next to the O(N²) or O(N·neighbours) pair sum.
#include "core/plugin_api.h"

namespace ff::phoretic {
void register_forces(Registry& r);
void register_integrate(Registry& r);
}  // namespace ff::phoretic

static void register_phoretic(ff::Registry& r) {
  ff::phoretic::register_forces(r);
  ff::phoretic::register_integrate(r);
}

FLIPFLOW_PLUGIN(register_phoretic)
