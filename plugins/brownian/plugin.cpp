// The brownian model plugin: free Brownian motion of disks/spheres.
#include "core/plugin_api.h"

namespace ff::brownian {
void register_integrate(Registry& r);
}

static void register_brownian(ff::Registry& r) { ff::brownian::register_integrate(r); }

FLIPFLOW_PLUGIN(register_brownian)
