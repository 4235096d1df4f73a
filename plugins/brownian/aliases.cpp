// The brownian model plugin: free Brownian motion of disks/spheres. Its stage is the standard
// overdamped integrator with no drift, under the name pipelines have always used.
#include "core/stage/stage_registration.h"

[[maybe_unused]] static const bool registered =
    ff::add_alias("brownian.integrate", "overdamped.integrate", "free overdamped Brownian motion, x += sqrt(2DΔt)·ξ",
                  ff::param_values({{"drift", std::string("none")}, {"mobility", std::vector<double>{1.0}}}));
