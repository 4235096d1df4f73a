// phoretic.integrate: Carter et al. 2017, eq. 1, in flipflow's convention x += v Δt + sqrt(2DΔt) ξ
// with v from phoretic.forces: the standard overdamped integrator reading `velocity`, under the
// name pipelines have always used (and its old default D = 0.01). Carter writes ξ √(DΔt)
// (per-component variance DΔt), so his D is twice ours: pipelines/phoretic-c*.yaml set D = 0.005
// for his D = 0.01.
//
// Two stages rather than one fused kernel: phoretic.forces writes the pair velocity into the
// `velocity` field, the integrator moves the particles. The pair sum has two very different loop
// shapes (all pairs in shared-memory tiles, or Verlet rows) while the update is one elementwise
// step; keeping them apart writes the update once, lets other velocity sources feed the same
// integrator, and makes `velocity` an observable, for one extra read and write of N·d reals per
// step.
#include "core/stage/stage_registration.h"

[[maybe_unused]] static const bool registered = ff::add_alias(
    "phoretic.integrate", "overdamped.integrate", "x += v Δt + sqrt(2DΔt)·ξ with v from phoretic.forces",
    ff::param_values({{"drift", std::string("velocity")}, {"mobility", std::vector<double>{1.0}}}),
    ff::param_values({{"D", std::vector<double>{0.01}}}));
