// The abp model plugin: Active Brownian Particles (Carter et al. 2017, eq. 10-11), 2D and 3D.
#include "core/plugin_api.h"

namespace ff::abp {
void register_integrate(Registry& r);
}

static void register_abp(ff::Registry& r) { ff::abp::register_integrate(r); }

FLIPFLOW_PLUGIN(register_abp)
